#include "node/node.hpp"

#include <spdlog/spdlog.h>

#include <chrono>

#include "app/program.hpp"
#include "transport/log_file.hpp"

namespace liloc::node {

int64_t wall_clock_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

bool run_nodes(transport::Transport& transport, const std::vector<Node*>& nodes,
               const RunConfig& config) {
  const auto tick_period_us = static_cast<int64_t>(config.tick_period_s * 1e6);
  int64_t next_tick_us = 0;
  bool end_of_input = false;
  while (!shutdown_requested()) {
    if (transport.handle(config.handle_timeout_ms) < 0) {
      end_of_input = true;
      break;
    }
    for (Node* n : nodes) {
      for (transport::Transport* own : n->own_transports()) {
        own->drain();
      }
    }
    const int64_t now = wall_clock_us();
    if (now >= next_tick_us) {
      for (Node* n : nodes) {
        n->tick(now);
      }
      next_tick_us = now + tick_period_us;
    }
  }
  spdlog::debug("{}: finishing", end_of_input ? "end of input" : "shutdown");
  bool ok = true;
  if (const transport::LogDamage* damage = transport.log_damage(); damage && damage->any()) {
    spdlog::error("the input log was damaged: {}", damage->summary());
    ok = false;
  }
  for (Node* n : nodes) {
    if (!n->finish()) {
      spdlog::error("{}: finished with data lost (see above)", n->name());
      ok = false;
    }
  }
  return ok;
}

}  // namespace liloc::node
