#include "imu/imu_buffer.hpp"

#include <algorithm>

namespace liloc {

ImuBuffer::AddResult ImuBuffer::add(const ImuSample& sample) {
  if (!sample.accel_mps2.allFinite() || !sample.gyro_rps.allFinite()) {
    ++counters_.non_finite;
    return AddResult::kNonFinite;
  }
  if (!samples_.empty()) {
    if (sample.utime_us == samples_.back().utime_us) {
      ++counters_.duplicate;
      return AddResult::kDuplicate;
    }
    if (sample.utime_us < samples_.back().utime_us) {
      ++counters_.out_of_order;
      return AddResult::kOutOfOrder;
    }
  }
  samples_.push_back(sample);
  ++counters_.accepted;
  return AddResult::kAccepted;
}

std::vector<ImuSample> ImuBuffer::between(int64_t t0_us, int64_t t1_us) const {
  std::vector<ImuSample> out;
  const auto first_after =
      std::upper_bound(samples_.begin(), samples_.end(), t0_us,
                       [](int64_t t, const ImuSample& s) { return t < s.utime_us; });
  auto it = first_after == samples_.begin() ? first_after : first_after - 1;
  for (; it != samples_.end() && it->utime_us <= t1_us; ++it) {
    out.push_back(*it);
  }
  return out;
}

void ImuBuffer::drop_before(int64_t t_us) {
  while (samples_.size() > 1 && samples_[1].utime_us <= t_us) {
    samples_.pop_front();
  }
}

}  // namespace liloc
