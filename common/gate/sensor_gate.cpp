#include "gate/sensor_gate.hpp"

#include <cmath>
#include <stdexcept>

namespace liloc {

void SensorLimits::validate() const {
  if (!(max_scan_period_s > 0.0 && max_scan_period_s <= 60.0)) {
    throw std::invalid_argument("max_scan_period_s must be in (0, 60]");
  }
  if (!(min_scan_interval_s >= 0.0 && min_scan_interval_s < 1.0)) {
    throw std::invalid_argument("min_scan_interval_s must be in [0, 1)");
  }
  if (max_scan_points < 1) {
    throw std::invalid_argument("max_scan_points must be at least 1");
  }
  if (!(accel_limit_mps2 > 0.0 && std::isfinite(accel_limit_mps2)) ||
      !(gyro_limit_rps > 0.0 && std::isfinite(gyro_limit_rps))) {
    throw std::invalid_argument("accel_limit_mps2 and gyro_limit_rps must be positive and finite");
  }
  if (!(max_time_jump_s > 0.0 && max_time_jump_s <= 86400.0) || confirm_jump_messages < 1) {
    throw std::invalid_argument(
        "max_time_jump_s must be in (0, 86400] and confirm_jump_messages at least 1");
  }
}

std::optional<std::string> implausible_scan(const LidarScan& scan, const SensorLimits& limits) {
  if (!std::isfinite(scan.scan_period_s)) {
    return "period " + std::to_string(scan.scan_period_s) + " s is not finite";
  }
  if (scan.scan_period_s < 0.0 || scan.scan_period_s > limits.max_scan_period_s) {
    return "period " + std::to_string(scan.scan_period_s) + " s is outside [0, " +
           std::to_string(limits.max_scan_period_s) + "]";
  }
  if (scan.utime_us <= 0) {
    return "time " + std::to_string(scan.utime_us) + " us is not after 1970";
  }
  if (scan.points.size() > static_cast<size_t>(limits.max_scan_points)) {
    return std::to_string(scan.points.size()) + " points, more than " +
           std::to_string(limits.max_scan_points);
  }
  return std::nullopt;
}

std::optional<std::string> implausible_imu(const ImuSample& sample, const SensorLimits& limits) {
  if (!sample.accel_mps2.allFinite() || !sample.gyro_rps.allFinite()) {
    return "a value is not finite";
  }
  if (sample.utime_us <= 0) {
    return "time " + std::to_string(sample.utime_us) + " us is not after 1970";
  }
  const double accel = sample.accel_mps2.cwiseAbs().maxCoeff();
  if (accel > limits.accel_limit_mps2) {
    return "acceleration " + std::to_string(accel) + " m/s^2 beyond the limit " +
           std::to_string(limits.accel_limit_mps2);
  }
  const double gyro = sample.gyro_rps.cwiseAbs().maxCoeff();
  if (gyro > limits.gyro_limit_rps) {
    return "rate " + std::to_string(gyro) + " rad/s beyond the limit " +
           std::to_string(limits.gyro_limit_rps);
  }
  return std::nullopt;
}

StreamClock::StreamClock(double max_time_jump_s, int confirm_jump_messages)
    : max_jump_us_(static_cast<int64_t>(max_time_jump_s * 1e6)), confirm_(confirm_jump_messages) {}

StreamClock::Verdict StreamClock::check(int64_t utime_us) {
  // |a - b| <= max_jump without overflow for any int64 times.
  const auto near = [this](int64_t a, int64_t b) {
    return (a >= b ? static_cast<uint64_t>(a) - static_cast<uint64_t>(b)
                   : static_cast<uint64_t>(b) - static_cast<uint64_t>(a)) <=
           static_cast<uint64_t>(max_jump_us_);
  };
  if (!latest_us_ || near(utime_us, *latest_us_)) {
    latest_us_ = latest_us_ ? std::max(*latest_us_, utime_us) : utime_us;
    candidate_count_ = 0;
    return Verdict::kAccept;
  }
  if (candidate_count_ > 0 && near(utime_us, *candidate_latest_us_)) {
    ++candidate_count_;
    candidate_latest_us_ = std::max(*candidate_latest_us_, utime_us);
  } else {
    candidate_count_ = 1;
    candidate_latest_us_ = utime_us;
  }
  if (candidate_count_ >= confirm_) {
    latest_us_ = candidate_latest_us_;
    candidate_count_ = 0;
    ++new_timelines_;
    return Verdict::kNewTimeline;
  }
  ++jumps_;
  return Verdict::kJump;
}

}  // namespace liloc
