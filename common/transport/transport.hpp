#pragma once
// liloc's one interface over LCM: typed publish/subscribe with per-channel health
// counters. Processes talk through this class only; algorithm code never sees it.
//
// URLs: udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304 (default, loopback only),
// memq:// (in-process, deterministic, for tests and benchmarks), file:///x.lcmlog?speed=0
// (read a log as if it were the bus; speed S > 0 keeps the logged timing scaled by S, the
// default 1 is real time). A log is read by LogReader, which skips corrupt regions and
// reports them (log_damage()), and its events are dispatched through an in-process
// memq:// instance, one event per handle().
//
// Robustness: a message that does not decode (wrong fingerprint, truncated or corrupt
// bytes) or exceeds max_message_bytes is counted, logged (rate-limited) and skipped;
// a handler that throws is counted and logged; sequence gaps per sender count as drops,
// jumps beyond max_sequence_gap as sender restarts.

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace lcm {
class LCM;
class ReceiveBuffer;
class Subscription;
}  // namespace lcm

namespace liloc::transport {

struct TransportConfig {
  std::string url = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304";
  // Where to publish, if not on `url`: a process reading a log
  // (url: file:///in.lcmlog?speed=0) writes its output to another one
  // (publish_url: file:///out.lcmlog?mode=w), or onto the live bus.
  std::string publish_url;
  // Messages larger than this are neither published nor decoded. LiDAR scans of a
  // 128-beam sensor stay below it; submaps and map updates are chunked to fit.
  int max_message_bytes = 4 * 1024 * 1024;
  // Messages LCM queues per subscription before it drops the oldest (LCM's default is 30,
  // too few for a 400 Hz IMU while a scan is processed).
  int queue_capacity = 1000;
  // A sequence number further than this from its sender's last one (either way) means the
  // sender restarted: counted in sequence_resets, not as drops.
  int64_t max_sequence_gap = 100000;
  // Senders whose sequence numbers each subscription remembers; beyond it the least
  // recently heard is forgotten (senders_forgotten), so a flood of ids cannot grow memory.
  int max_senders = 256;
  // Replies addressed to one robot (the map server's submaps) go to a port of the robot's
  // own among this many after the bus's (node/reply_route.hpp); 0: on the bus itself.
  int reply_ports = 8;

  template <class V>
  void visit_fields(V& v) {
    v("url", url);
    v("publish_url", publish_url);
    v("max_message_bytes", max_message_bytes);
    v("queue_capacity", queue_capacity);
    v("max_sequence_gap", max_sequence_gap);
    v("max_senders", max_senders);
    v("reply_ports", reply_ports);
  }
  void validate() const;
};

// Health of one subscription, cumulative since start. The sequence counters are those of
// SequenceCounts (sequence_tracker.hpp), over the senders of typed messages.
struct ChannelStats {
  int64_t received = 0;           // decoded and handed to the handler
  int64_t decode_errors = 0;      // wrong type fingerprint, truncated or corrupt
  int64_t oversized = 0;          // larger than max_message_bytes, not decoded
  int64_t dropped = 0;            // missing sequence numbers (per sender)
  int64_t out_of_order = 0;       // sequence number not above the last one (repeat, reorder)
  int64_t handler_errors = 0;     // the handler threw
  int64_t sequence_resets = 0;    // a sender restarted (negative seq, back to 0, a jump)
  int64_t senders_forgotten = 0;  // over max_senders, least recently heard first
};

struct ReceiveInfo {
  const std::string& channel;
  int64_t recv_utime;  // wall-clock time LCM received (or, from a log, replayed) it
  size_t bytes;
};

struct LogDamage;  // log_file.hpp

class Transport {
 public:
  explicit Transport(const TransportConfig& config = {});
  ~Transport();
  Transport(const Transport&) = delete;
  Transport& operator=(const Transport&) = delete;

  // Typed publish: sets msg.header.seq from a per-channel counter, then encodes.
  // Returns false (counted, logged) if the message exceeds max_message_bytes or
  // LCM refuses it. Publishing is thread-safe (handle() is not: one thread dispatches).
  template <class Msg>
  bool publish(const std::string& channel, Msg& msg);

  // Typed subscribe to one channel (exact name, no regex). The handler runs inside
  // handle(); messages that fail to decode never reach it.
  template <class Msg>
  void subscribe(const std::string& channel,
                 std::function<void(const Msg&, const ReceiveInfo&)> handler);

  // Raw byte-level access, for recording and replay.
  bool publish_raw(const std::string& channel, const void* data, size_t size);
  using RawHandler = std::function<void(const void* data, size_t size, const ReceiveInfo&)>;
  void subscribe_raw(const std::string& channel_regex, RawHandler handler);

  // Dispatches messages. Waits up to timeout_ms for the first one, then also delivers
  // whatever else is already queued. Returns the number handled; -1 when the provider
  // ended (end of a file:// log) or failed. From a file:// log: waits up to timeout_ms for
  // the next event to be due, and dispatches that one event.
  int handle(int timeout_ms);

  // Handles everything already queued without waiting (in-process memq:// pipelines).
  int drain();

  // Cumulative counters per subscribed channel, and publish failures.
  std::map<std::string, ChannelStats> stats() const;
  int64_t publish_errors() const { return publish_errors_.load(); }

  // Reading a file:// log: what the reader has skipped so far; null for any other URL.
  const LogDamage* log_damage() const;

  const TransportConfig& config() const { return config_; }

 private:
  struct Subscription;
  struct LogSource;
  using Decoder = std::function<bool(const void* data, size_t size, const ReceiveInfo& info,
                                     Subscription& sub)>;

  void add_subscription(const std::string& channel, bool is_regex, Decoder decoder);
  void on_message(const lcm::ReceiveBuffer* rbuf, const std::string& channel, Subscription* sub);
  void warn(Subscription& sub, const std::string& what, int64_t count);
  // Sends with publish_mutex_ held; counts and logs a failure.
  bool send_locked(const std::string& channel, const void* data, size_t size);
  void count_publish_error(const std::string& what);
  int handle_log_event(int timeout_ms);

  TransportConfig config_;
  std::unique_ptr<LogSource> log_;         // reading a file:// log
  std::unique_ptr<lcm::LCM> lcm_;          // memq:// when reading a log
  std::unique_ptr<lcm::LCM> publish_lcm_;  // only with a separate publish_url
  std::vector<std::unique_ptr<Subscription>> subscriptions_;
  std::mutex publish_mutex_;  // guards next_seq_ and the LCM send, taken together
  std::map<std::string, int64_t> next_seq_;
  std::atomic<int64_t> publish_errors_{0};
};

}  // namespace liloc::transport

#include "transport/transport_impl.hpp"
