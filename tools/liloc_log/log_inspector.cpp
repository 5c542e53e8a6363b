#include "liloc_log/log_inspector.hpp"

#include <cstdio>
#include <functional>

#include "bridge/message_samples.hpp"
#include "transport/log_file.hpp"
#include "transport/sequence_tracker.hpp"

namespace liloc::tools {
namespace {

// Decodes one message of a known type and reports its sender and sequence number.
using HeaderReader =
    std::function<bool(const transport::LogEventView&, std::string& sender, int64_t& seq)>;

template <class Msg>
HeaderReader header_reader() {
  return [](const transport::LogEventView& event, std::string& sender, int64_t& seq) {
    Msg msg;
    if (!transport::decode(event, msg)) {
      return false;
    }
    if constexpr (bridge::HasHeader<Msg>::value) {
      sender = msg.header.robot_id;
      seq = msg.header.seq;
    }
    return true;
  };
}

struct KnownType {
  std::string name;
  HeaderReader read;
  bool has_header;
};

std::map<int64_t, KnownType> known_types() {
  std::map<int64_t, KnownType> types;
#define LILOC_REGISTER(type)                                            \
  types[liloc::type::getHash()] = {#type, header_reader<liloc::type>(), \
                                   bridge::HasHeader<liloc::type>::value};
  LILOC_FOR_EACH_LCM_TYPE(LILOC_REGISTER)
#undef LILOC_REGISTER
  return types;
}

int64_t read_fingerprint(const transport::LogEventView& event) {
  if (event.size < 8) {
    return 0;
  }
  const auto* b = static_cast<const uint8_t*>(event.data);
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) {
    v = (v << 8) | b[i];  // LCM encodes big-endian
  }
  return static_cast<int64_t>(v);
}
}  // namespace

LogSummary summarize_log(const std::string& path) {
  const std::map<int64_t, KnownType> types = known_types();
  // The transport's rules, so that the counts match what a process would report.
  const transport::TransportConfig transport_defaults;
  LogSummary summary;
  std::map<std::string, transport::SequenceTracker> sequences;  // by channel
  transport::LogReader reader(path);
  transport::LogEventView event;
  while (reader.next(event)) {
    ChannelSummary& s = summary.channels[event.channel];
    if (s.messages == 0) {
      s.first_utime = event.utime;
    }
    ++s.messages;
    s.bytes += static_cast<int64_t>(event.size);
    s.last_utime = event.utime;
    const auto type = types.find(read_fingerprint(event));
    if (type == types.end()) {
      s.type = "unknown";
      continue;
    }
    s.type = type->second.name;
    std::string sender;
    int64_t seq = -1;
    if (!type->second.read(event, sender, seq)) {
      ++s.decode_errors;
      continue;
    }
    if (type->second.has_header) {
      sequences
          .try_emplace(event.channel, transport_defaults.max_sequence_gap,
                       transport_defaults.max_senders)
          .first->second.track(sender, seq);
    }
  }
  for (const auto& [channel, tracker] : sequences) {
    ChannelSummary& s = summary.channels[channel];
    s.sequence_gaps = tracker.counts().dropped;
    s.out_of_order = tracker.counts().out_of_order;
    s.sequence_resets = tracker.counts().sequence_resets;
  }
  summary.damage = reader.damage();
  return summary;
}

std::string format_summary(const LogSummary& summary) {
  std::string out;
  char line[512];
  std::snprintf(line, sizeof(line), "%-32s %-18s %9s %11s %8s %7s %6s %6s %6s\n", "channel", "type",
                "messages", "MB", "Hz", "undecod", "gaps", "order", "resets");
  out += line;
  for (const auto& [channel, s] : summary.channels) {
    const double duration_s = (s.last_utime - s.first_utime) * 1e-6;
    const double hz = duration_s > 0 ? (s.messages - 1) / duration_s : 0.0;
    std::snprintf(line, sizeof(line), "%-32s %-18s %9lld %11.3f %8.2f %7lld %6lld %6lld %6lld\n",
                  channel.c_str(), s.type.c_str(), static_cast<long long>(s.messages),
                  s.bytes / 1e6, hz, static_cast<long long>(s.decode_errors),
                  static_cast<long long>(s.sequence_gaps), static_cast<long long>(s.out_of_order),
                  static_cast<long long>(s.sequence_resets));
    out += line;
  }
  const transport::LogDamage& damage = summary.damage;
  if (!damage.any()) {
    return out;
  }
  out += "damaged log: " + damage.summary() + "\n";
  for (const transport::SkippedRegion& region : damage.regions) {
    out += "  corrupt region at byte offset " + std::to_string(region.offset) + ": " +
           std::to_string(region.bytes) + " bytes skipped\n";
  }
  const int64_t unlisted = damage.corrupt_regions - static_cast<int64_t>(damage.regions.size());
  if (unlisted > 0) {
    out += "  ... and " + std::to_string(unlisted) + " more corrupt regions\n";
  }
  return out;
}

}  // namespace liloc::tools
