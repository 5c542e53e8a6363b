#include "transport/transport.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <lcm/lcm-cpp.hpp>
#include <optional>
#include <sstream>
#include <thread>

#include "app/rate_limit.hpp"
#include "transport/log_file.hpp"

namespace liloc::transport {
namespace {

constexpr int64_t kMessageLogPeriod = 1000;
// Bounds the per-subscription sender table of a misconfigured process.
constexpr int kMostSenders = 1000000;

struct LogUrl {
  std::string path;
  double speed = 1.0;  // LCM's default: real time
};

// A file:// URL that LCM would open for reading; nullopt for any other URL, including a
// file:// log opened for writing (mode=w or a), which LCM's provider keeps handling.
// Unknown options are refused: a misspelt speed=0 would otherwise replay in real time.
std::optional<LogUrl> parse_log_url(const std::string& url) {
  const std::string scheme = "file://";
  if (url.rfind(scheme, 0) != 0) {
    return std::nullopt;
  }
  const size_t query = url.find('?');
  LogUrl log{url.substr(scheme.size(), query - scheme.size())};
  if (log.path.empty()) {
    throw std::invalid_argument("LCM URL '" + url + "' names no file");
  }
  if (query == std::string::npos) {
    return log;
  }
  std::istringstream options(url.substr(query + 1));
  for (std::string option; std::getline(options, option, '&');) {
    const size_t equals = option.find('=');
    const std::string key = option.substr(0, equals);
    const std::string value = equals == std::string::npos ? "" : option.substr(equals + 1);
    if (key == "mode" && (value == "w" || value == "a")) {
      return std::nullopt;
    }
    if (key == "mode" && value == "r") {
      continue;
    }
    if (key == "speed") {
      char* end = nullptr;
      log.speed = std::strtod(value.c_str(), &end);
      if (!value.empty() && *end == '\0') {
        continue;  // ReplayClock refuses a negative or non-finite speed
      }
    }
    throw std::invalid_argument("LCM URL '" + url + "': option '" + option +
                                "' is not speed=S (S >= 0, 0: at once) or mode=r|w|a");
  }
  return log;
}

}  // namespace

// A file:// log: read by LogReader, each event dispatched when ReplayClock says it is due.
struct Transport::LogSource {
  LogSource(const std::string& path, double speed) : reader(path), clock(speed) {}
  LogReader reader;
  ReplayClock clock;
  LogEventView event;
  bool event_pending = false;  // read, not yet due
};

void TransportConfig::validate() const {
  if (url.empty()) {
    throw std::invalid_argument("url must not be empty");
  }
  if (max_message_bytes < 1024) {
    throw std::invalid_argument("max_message_bytes must be at least 1024");
  }
  if (queue_capacity < 1) {
    throw std::invalid_argument("queue_capacity must be at least 1");
  }
  if (max_sequence_gap < 1) {
    throw std::invalid_argument("max_sequence_gap must be at least 1");
  }
  if (max_senders < 1 || max_senders > kMostSenders) {
    throw std::invalid_argument("max_senders must be in [1, " + std::to_string(kMostSenders) + "]");
  }
  if (reply_ports < 0 || reply_ports > 64) {
    throw std::invalid_argument("reply_ports must be in [0, 64]");
  }
}

Transport::Transport(const TransportConfig& config) : config_(config) {
  config_.validate();
  if (const std::optional<LogUrl> log = parse_log_url(config.url)) {
    log_ = std::make_unique<LogSource>(log->path, log->speed);
  }
  // A log's events go through an in-process instance, so that subscriptions, decoding and
  // counters work as on a bus.
  lcm_ = std::make_unique<lcm::LCM>(log_ ? "memq://" : config.url);
  if (!lcm_->good()) {
    throw std::runtime_error("cannot open LCM provider '" + config.url +
                             "' (for udpm on loopback check the multicast route)");
  }
  if (!config.publish_url.empty() && config.publish_url != config.url) {
    publish_lcm_ = std::make_unique<lcm::LCM>(config.publish_url);
    if (!publish_lcm_->good()) {
      throw std::runtime_error("cannot open LCM provider '" + config.publish_url +
                               "' for publishing");
    }
  }
  if (config.url.rfind("udpm://", 0) == 0 &&
      config.url.find("recv_buf_size") == std::string::npos) {
    spdlog::warn(
        "LCM URL '{}' sets no recv_buf_size: large messages (scans, submaps) will be lost "
        "with the kernel's default receive buffer",
        config.url);
  }
}

Transport::~Transport() = default;

bool Transport::publish_raw(const std::string& channel, const void* data, size_t size) {
  std::lock_guard<std::mutex> lock(publish_mutex_);
  return send_locked(channel, data, size);
}

bool Transport::send_locked(const std::string& channel, const void* data, size_t size) {
  if (size > static_cast<size_t>(config_.max_message_bytes)) {
    count_publish_error("not publishing " + std::to_string(size) + " bytes on " + channel +
                        ": over max_message_bytes = " + std::to_string(config_.max_message_bytes));
    return false;
  }
  if (log_ && !publish_lcm_) {
    count_publish_error("not publishing on " + channel + ": the transport reads the log " +
                        config_.url + "; set publish_url to publish");
    return false;
  }
  lcm::LCM& out = publish_lcm_ ? *publish_lcm_ : *lcm_;
  if (out.publish(channel, data, static_cast<unsigned int>(size)) != 0) {
    count_publish_error("LCM failed to publish " + std::to_string(size) + " bytes on " + channel);
    return false;
  }
  return true;
}

void Transport::count_publish_error(const std::string& what) {
  const int64_t count = ++publish_errors_;
  if (should_log(count, kMessageLogPeriod)) {
    spdlog::error("{} (publish error #{})", what, count);
  }
}

void Transport::subscribe_raw(const std::string& channel_regex, RawHandler handler) {
  add_subscription(channel_regex, true,
                   [handler = std::move(handler)](const void* data, size_t size,
                                                  const ReceiveInfo& info, Subscription&) {
                     handler(data, size, info);
                     return true;
                   });
}

void Transport::add_subscription(const std::string& channel, bool is_regex, Decoder decoder) {
  auto sub = std::make_unique<Subscription>(channel, std::move(decoder), this);
  Subscription* raw = sub.get();
  // LCM treats every channel string as a regex; quote an exact name's regex characters.
  std::string pattern = channel;
  if (!is_regex) {
    pattern.clear();
    for (const char c : channel) {
      if (std::string(".^$|()[]{}*+?\\").find(c) != std::string::npos) {
        pattern += '\\';
      }
      pattern += c;
    }
  }
  raw->lcm_subscription = lcm_->subscribeFunction(
      pattern,
      +[](const lcm::ReceiveBuffer* rbuf, const std::string& ch, Subscription* s) {
        s->owner->on_message(rbuf, ch, s);
      },
      raw);
  raw->lcm_subscription->setQueueCapacity(config_.queue_capacity);
  subscriptions_.push_back(std::move(sub));
}

void Transport::on_message(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
                           Subscription* sub) {
  ChannelStats& stats = sub->stats;
  const size_t size = rbuf->data_size;
  const ReceiveInfo info{channel, rbuf->recv_utime, size};
  if (size > static_cast<size_t>(config_.max_message_bytes)) {
    ++stats.oversized;
    warn(*sub, "message of " + std::to_string(size) + " bytes over max_message_bytes",
         stats.oversized);
    return;
  }
  try {
    if (!sub->decode(rbuf->data, size, info, *sub)) {
      ++stats.decode_errors;
      warn(*sub,
           "message of " + std::to_string(size) +
               " bytes does not decode (wrong type fingerprint, truncated or corrupt)",
           stats.decode_errors);
      return;
    }
    ++stats.received;
  } catch (const std::exception& e) {
    ++stats.handler_errors;
    warn(*sub, std::string("handler failed: ") + e.what(), stats.handler_errors);
  }
}

void Transport::warn(Subscription& sub, const std::string& what, int64_t count) {
  if (should_log(count, kMessageLogPeriod)) {
    spdlog::warn("{}: {} (#{})", sub.channel, what, count);
  }
}

int Transport::handle(int timeout_ms) {
  if (log_) {
    return handle_log_event(timeout_ms);
  }
  const int first = lcm_->handleTimeout(timeout_ms);
  if (first < 0) {
    return -1;
  }
  if (first == 0) {
    return 0;
  }
  return 1 + drain();
}

// One event per call, so that nodes are ticked between events however fast the log plays.
int Transport::handle_log_event(int timeout_ms) {
  LogSource& log = *log_;
  if (!log.event_pending) {
    if (!log.reader.next(log.event)) {
      return -1;
    }
    log.event_pending = true;
  }
  const auto due = log.clock.due(log.event.utime);
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::milliseconds(std::max(timeout_ms, 0));
  if (due > deadline) {
    std::this_thread::sleep_until(deadline);
    return 0;
  }
  std::this_thread::sleep_until(due);
  log.event_pending = false;
  if (lcm_->publish(log.event.channel, log.event.data, static_cast<unsigned int>(log.event.size)) !=
      0) {
    count_publish_error("LCM refused to dispatch the logged event of " +
                        std::to_string(log.event.size) + " bytes on " + log.event.channel);
    return 0;
  }
  return drain();
}

int Transport::drain() {
  int handled = 0;
  while (true) {
    const int r = lcm_->handleTimeout(0);
    if (r <= 0) {
      return handled;
    }
    ++handled;
  }
}

std::map<std::string, ChannelStats> Transport::stats() const {
  std::map<std::string, ChannelStats> out;
  for (const auto& sub : subscriptions_) {
    ChannelStats s = sub->stats;
    const SequenceCounts& sequences = sub->sequences.counts();
    s.dropped = sequences.dropped;
    s.out_of_order = sequences.out_of_order;
    s.sequence_resets = sequences.sequence_resets;
    s.senders_forgotten = sequences.senders_forgotten;
    out[sub->channel] = s;
  }
  return out;
}

const LogDamage* Transport::log_damage() const { return log_ ? &log_->reader.damage() : nullptr; }

}  // namespace liloc::transport
