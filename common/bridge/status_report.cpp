#include "bridge/status_report.hpp"

#include "bridge/lcm_conversions.hpp"
#include "transport/log_file.hpp"

namespace liloc::bridge {

void StatusReport::add_transport_counters(const transport::Transport& bus) {
  for (const auto& [channel, s] : bus.stats()) {
    counters.emplace_back(channel + ".received", s.received);
    counters.emplace_back(channel + ".dropped", s.dropped);
    counters.emplace_back(channel + ".decode_errors", s.decode_errors);
    counters.emplace_back(channel + ".oversized", s.oversized);
    counters.emplace_back(channel + ".out_of_order", s.out_of_order);
    counters.emplace_back(channel + ".handler_errors", s.handler_errors);
    counters.emplace_back(channel + ".sequence_resets", s.sequence_resets);
    counters.emplace_back(channel + ".senders_forgotten", s.senders_forgotten);
  }
  counters.emplace_back("publish_errors", bus.publish_errors());
  if (const transport::LogDamage* damage = bus.log_damage()) {
    counters.emplace_back("log.corrupt_regions", damage->corrupt_regions);
    counters.emplace_back("log.bytes_skipped", damage->bytes_skipped);
    counters.emplace_back("log.truncated_end", damage->truncated_end ? 1 : 0);
  }
}

liloc::status_t to_msg(const StatusReport& report, int64_t utime, const std::string& robot_id) {
  liloc::status_t msg;
  msg.header = make_header(utime, robot_id, "");
  msg.process = report.process;
  msg.mode = report.mode;
  msg.overlap = report.overlap;
  msg.fitness = report.fitness;
  msg.degenerate = report.degenerate;
  msg.min_eigenvalue = report.min_eigenvalue;
  for (const auto& [name, ms] : report.timings_ms) {
    msg.timing_names.push_back(name);
    msg.timing_ms.push_back(ms);
  }
  msg.num_timings = static_cast<int32_t>(msg.timing_names.size());
  for (const auto& [name, value] : report.counters) {
    msg.counter_names.push_back(name);
    msg.counter_values.push_back(value);
  }
  msg.num_counters = static_cast<int32_t>(msg.counter_names.size());
  msg.message = report.message;
  return msg;
}

}  // namespace liloc::bridge
