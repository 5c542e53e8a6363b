#pragma once
// Per-channel summary of an LCM log: message type (recognized by its fingerprint),
// count, size, rate, decode failures and sequence gaps per sender; and the log's damage
// (corrupt regions and a truncated end, with their byte offsets).

#include <cstdint>
#include <map>
#include <string>

#include "transport/log_file.hpp"

namespace liloc::tools {

struct ChannelSummary {
  std::string type;  // liloc type name, or "unknown" if no liloc type has the fingerprint
  int64_t messages = 0;
  int64_t bytes = 0;
  int64_t first_utime = 0;
  int64_t last_utime = 0;
  int64_t decode_errors = 0;    // fingerprint known, bytes do not decode
  int64_t sequence_gaps = 0;    // missing header.seq values, summed over senders
  int64_t out_of_order = 0;     // header.seq not above the sender's previous one
  int64_t sequence_resets = 0;  // a sender restarted (the transport's rules)
};

struct LogSummary {
  std::map<std::string, ChannelSummary> channels;
  transport::LogDamage damage;
};

// Reads the whole log; throws std::runtime_error naming the file if it cannot be read.
LogSummary summarize_log(const std::string& path);

// A table for humans, one line per channel, then the damage with byte offsets.
std::string format_summary(const LogSummary& summary);

}  // namespace liloc::tools
