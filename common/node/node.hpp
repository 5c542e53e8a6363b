#pragma once
// A node: the logic of one liloc process over a Transport, in the shape of Drake's systems
// on a DrakeLcmInterface. It subscribes in its constructor, reacts to messages inside
// Transport::handle(), and is ticked for periodic work (status, timeouts, saves). A
// process's main() parses its arguments, builds the transport and runs its node; tests,
// benchmarks and the deterministic pipeline compose several nodes on one memq://
// transport, where what one node publishes reaches the others at the next drain().

#include <cstdint>
#include <string>
#include <vector>

#include "transport/transport.hpp"

namespace liloc::node {

class Node {
 public:
  virtual ~Node() = default;
  // For logs: "odometry", "map_server", ...
  virtual std::string name() const = 0;
  // Periodic work, on the thread that handles messages, with the wall-clock time (µs since
  // the epoch). Nodes keep no timer threads of their own for it.
  virtual void tick(int64_t now_us) { (void)now_us; }
  // No more input will come (end of a log, shutdown): finish what is buffered. False if
  // something was lost (the node logged what), so that the process exits non-zero.
  virtual bool finish() { return true; }
  // Transports the node listens on besides the one it was given (its reply route:
  // node/reply_route.hpp); run_nodes() dispatches them too.
  virtual std::vector<transport::Transport*> own_transports() { return {}; }
};

struct RunConfig {
  int handle_timeout_ms = 50;  // the longest the loop waits for a message
  double tick_period_s = 0.1;  // nodes are ticked at least this often
};

// Wall-clock time, µs since the Unix epoch.
int64_t wall_clock_us();

// Dispatches the transport's messages to the nodes' subscriptions and ticks the nodes until
// shutdown is requested (SIGINT, SIGTERM: app/program.hpp) or the input ends (a file://
// log), then finishes them in order. True if every node finished without loss and the
// input log, if any, was undamaged.
bool run_nodes(transport::Transport& transport, const std::vector<Node*>& nodes,
               const RunConfig& config = {});

}  // namespace liloc::node
