#include "transport/transport.hpp"

#include <spdlog/spdlog.h>

#include <lcm/lcm-cpp.hpp>

namespace liloc::transport {
namespace {
// Log the first few occurrences of a problem, then every 1000th, so that a flood of bad
// messages stays visible without drowning the log.
bool should_log(int64_t count) { return count <= 5 || count % 1000 == 0; }
}  // namespace

void TransportConfig::validate() const {
  if (url.empty()) {
    throw std::invalid_argument("must not be empty");
  }
  if (max_message_bytes < 1024) {
    throw std::invalid_argument("max_message_bytes must be at least 1024");
  }
  if (queue_capacity < 1) {
    throw std::invalid_argument("queue_capacity must be at least 1");
  }
}

Transport::Transport(const TransportConfig& config)
    : config_(config), lcm_(std::make_unique<lcm::LCM>(config.url)) {
  config_.validate();
  if (!lcm_->good()) {
    throw std::runtime_error("cannot open LCM provider '" + config.url +
                             "' (for udpm on loopback check the multicast route; for file:// "
                             "check the path)");
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
    ++publish_errors_;
    if (should_log(publish_errors_)) {
      spdlog::error("not publishing {} bytes on {}: over max_message_bytes = {}", size, channel,
                    config_.max_message_bytes);
    }
    return false;
  }
  lcm::LCM& out = publish_lcm_ ? *publish_lcm_ : *lcm_;
  if (out.publish(channel, data, static_cast<unsigned int>(size)) != 0) {
    ++publish_errors_;
    if (should_log(publish_errors_)) {
      spdlog::error("LCM failed to publish {} bytes on {}", size, channel);
    }
    return false;
  }
  return true;
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
  auto sub = std::make_unique<Subscription>();
  sub->channel = channel;
  sub->decode = std::move(decoder);
  sub->owner = this;
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
  if (should_log(count)) {
    spdlog::warn("{}: {} (#{})", sub.channel, what, count);
  }
}

void Transport::track_sequence(Subscription& sub, const std::string& sender, int64_t seq) {
  auto [it, first] = sub.last_seq_by_sender.try_emplace(sender, seq);
  if (first) {
    return;
  }
  int64_t& last = it->second;
  if (seq > last) {
    sub.stats.dropped += seq - last - 1;
    last = seq;
  } else {
    ++sub.stats.out_of_order;
    if (seq == 0) {
      last = 0;  // the sender restarted
    }
  }
}

int Transport::handle(int timeout_ms) {
  const int first = lcm_->handleTimeout(timeout_ms);
  if (first < 0) {
    return -1;
  }
  if (first == 0) {
    return 0;
  }
  return 1 + drain();
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
    out[sub->channel] = sub->stats;
  }
  return out;
}

}  // namespace liloc::transport
