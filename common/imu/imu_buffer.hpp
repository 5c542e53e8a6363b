#pragma once
// Time-ordered IMU samples as they arrive from the wire: refuses what would corrupt
// integration (non-finite values, repeated or out-of-order times) with a count, and
// answers "which samples cover [t0, t1]" for propagation.

#include <cstdint>
#include <deque>
#include <vector>

#include "imu/imu_sample.hpp"

namespace liloc {

class ImuBuffer {
 public:
  enum class AddResult { kAccepted, kNonFinite, kDuplicate, kOutOfOrder };

  struct Counters {
    int64_t accepted = 0;
    int64_t non_finite = 0;
    int64_t duplicate = 0;
    int64_t out_of_order = 0;
  };

  AddResult add(const ImuSample& sample);

  // Samples with time in (t0_us, t1_us], plus the last one at or before t0_us (so that
  // integration can start at t0), in order.
  std::vector<ImuSample> between(int64_t t0_us, int64_t t1_us) const;

  // Forgets samples older than the last one at or before t_us.
  void drop_before(int64_t t_us);

  bool empty() const { return samples_.empty(); }
  size_t size() const { return samples_.size(); }
  int64_t first_utime() const { return samples_.front().utime_us; }
  int64_t last_utime() const { return samples_.back().utime_us; }
  const std::deque<ImuSample>& samples() const { return samples_; }
  const Counters& counters() const { return counters_; }

 private:
  std::deque<ImuSample> samples_;
  Counters counters_;
};

}  // namespace liloc
