#pragma once
// What the header.seq numbers of one channel say about loss, per sender: a subscription
// of Transport and liloc_log info both count with it.

#include <cstdint>
#include <list>
#include <string>
#include <unordered_map>

namespace liloc::transport {

struct SequenceCounts {
  int64_t dropped = 0;            // missing sequence numbers within a plausible gap
  int64_t out_of_order = 0;       // not above the sender's last one (repeat, reorder)
  int64_t sequence_resets = 0;    // the sender restarted: negative, back to 0 or a jump
  int64_t senders_forgotten = 0;  // evicted over max_senders, least recently heard first
};

class SequenceTracker {
 public:
  // max_gap: a jump by more than this (either way) is a restart, not a loss.
  // max_senders: senders remembered at once; bounds memory against a flood of ids.
  SequenceTracker(int64_t max_gap, int max_senders);

  void track(const std::string& sender, int64_t seq);

  const SequenceCounts& counts() const { return counts_; }
  size_t senders() const { return by_sender_.size(); }

 private:
  struct Sender {
    std::string id;
    int64_t last_seq = -1;  // -1: no anchor yet (new sender, or after a negative seq)
  };
  // Re-anchors `sender` after a restart.
  void reset(Sender& sender, int64_t seq);

  int64_t max_gap_;
  size_t max_senders_;
  std::list<Sender> recent_first_;  // most recently heard sender at the front
  std::unordered_map<std::string, std::list<Sender>::iterator> by_sender_;
  SequenceCounts counts_;
};

}  // namespace liloc::transport
