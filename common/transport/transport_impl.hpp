#pragma once
// Template part of transport.hpp; include transport.hpp, not this file.

#include <new>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "transport/sequence_tracker.hpp"

namespace liloc::transport {

struct Transport::Subscription {
  Subscription(std::string channel_name, Decoder decoder, Transport* transport)
      : channel(std::move(channel_name)),
        decode(std::move(decoder)),
        sequences(transport->config_.max_sequence_gap, transport->config_.max_senders),
        owner(transport) {}

  std::string channel;
  Decoder decode;
  ChannelStats stats;  // the receive counters; stats() adds those of `sequences`
  SequenceTracker sequences;
  lcm::Subscription* lcm_subscription = nullptr;
  Transport* owner;
};

template <class Msg>
bool Transport::publish(const std::string& channel, Msg& msg) {
  // The sequence number is taken and the message sent under one lock: with several
  // publishing threads, message n + 1 never leaves before message n.
  std::lock_guard<std::mutex> lock(publish_mutex_);
  msg.header.seq = next_seq_[channel]++;
  const int size = msg.getEncodedSize();
  std::vector<uint8_t> buffer(static_cast<size_t>(size));
  if (msg.encode(buffer.data(), 0, size) != size) {
    ++publish_errors_;
    return false;
  }
  return send_locked(channel, buffer.data(), buffer.size());
}

template <class Msg>
void Transport::subscribe(const std::string& channel,
                          std::function<void(const Msg&, const ReceiveInfo&)> handler) {
  add_subscription(channel, false,
                   [handler = std::move(handler)](const void* data, size_t size,
                                                  const ReceiveInfo& info, Subscription& sub) {
                     Msg msg;
                     int used = -1;
                     try {
                       used = msg.decode(data, 0, static_cast<int>(size));
                     } catch (const std::bad_alloc&) {
                       used = -1;
                     } catch (const std::length_error&) {
                       used = -1;
                     }
                     if (used < 0) {
                       return false;
                     }
                     sub.sequences.track(msg.header.robot_id, msg.header.seq);
                     handler(msg, info);
                     return true;
                   });
}

}  // namespace liloc::transport
