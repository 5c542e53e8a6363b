#include "transport/sequence_tracker.hpp"

#include <stdexcept>

namespace liloc::transport {

SequenceTracker::SequenceTracker(int64_t max_gap, int max_senders)
    : max_gap_(max_gap), max_senders_(static_cast<size_t>(max_senders)) {
  if (max_gap < 1 || max_senders < 1) {
    throw std::invalid_argument("SequenceTracker: max_gap and max_senders must be positive");
  }
}

void SequenceTracker::track(const std::string& id, int64_t seq) {
  const auto found = by_sender_.find(id);
  if (found != by_sender_.end()) {
    recent_first_.splice(recent_first_.begin(), recent_first_, found->second);
  } else {
    if (by_sender_.size() == max_senders_) {
      by_sender_.erase(recent_first_.back().id);
      recent_first_.pop_back();
      ++counts_.senders_forgotten;
    }
    recent_first_.push_front(Sender{id, -1});
    by_sender_.emplace(id, recent_first_.begin());
  }
  Sender& sender = recent_first_.front();
  if (seq < 0) {
    reset(sender, -1);  // no number to count from; the next one anchors
    return;
  }
  if (sender.last_seq < 0) {
    sender.last_seq = seq;
    return;
  }
  // Both are non-negative from here, so the differences cannot overflow.
  if (seq > sender.last_seq) {
    const int64_t missing = seq - sender.last_seq - 1;
    if (missing > max_gap_) {
      reset(sender, seq);
    } else {
      counts_.dropped += missing;
      sender.last_seq = seq;
    }
  } else if ((seq == 0 && sender.last_seq > 0) || sender.last_seq - seq > max_gap_) {
    reset(sender, seq);  // counting from 0 again, or far back: a restarted publisher
  } else {
    ++counts_.out_of_order;
  }
}

void SequenceTracker::reset(Sender& sender, int64_t seq) {
  ++counts_.sequence_resets;
  sender.last_seq = seq;
}

}  // namespace liloc::transport
