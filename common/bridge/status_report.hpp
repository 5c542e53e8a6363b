#pragma once
// What every process tells about itself on its status channel: mode, registration
// quality, per-stage timings of the latest cycle and cumulative counters (including the
// transport's drop and decode-error counts).

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "liloc/status_t.hpp"
#include "transport/transport.hpp"

namespace liloc::bridge {

struct StatusReport {
  std::string process;
  int8_t mode = liloc::status_t::MODE_NONE;
  float overlap = -1.0f;
  float fitness = -1.0f;
  bool degenerate = false;
  float min_eigenvalue = -1.0f;
  std::vector<std::pair<std::string, float>> timings_ms;  // "total" is the whole cycle
  std::vector<std::pair<std::string, int64_t>> counters;
  std::string message;

  // Adds "<channel>.received", ".dropped", ".decode_errors", ".oversized",
  // ".out_of_order", ".handler_errors", ".sequence_resets", ".senders_forgotten" for every
  // subscription, "publish_errors", and when the transport reads a log what its reader
  // skipped: "log.corrupt_regions", "log.bytes_skipped", "log.truncated_end" (0 or 1).
  void add_transport_counters(const transport::Transport& bus);
};

liloc::status_t to_msg(const StatusReport& report, int64_t utime, const std::string& robot_id);

}  // namespace liloc::bridge
