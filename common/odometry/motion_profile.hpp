#pragma once
// The body's motion over an interval, as piecewise constant angular rate and
// acceleration between samples: what deskewing asks "where was the body at time t?".

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

namespace liloc {

struct MotionSample {
  int64_t utime_us = 0;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // R_local_body at utime_us
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  Eigen::Vector3d omega_body = Eigen::Vector3d::Zero();   // rad/s, until the next sample
  Eigen::Vector3d accel_local = Eigen::Vector3d::Zero();  // m/s^2, gravity included
};

class MotionProfile {
 public:
  void clear() { samples_.clear(); }
  // Samples must come in increasing time.
  void add(const MotionSample& sample) { samples_.push_back(sample); }
  bool empty() const { return samples_.empty(); }
  const std::vector<MotionSample>& samples() const { return samples_; }

  // T_local_body at t: from the last sample at or before t (the first one for earlier
  // times), moving with its rates.
  Eigen::Isometry3d pose_at(int64_t t_us) const;

 private:
  std::vector<MotionSample> samples_;
};

}  // namespace liloc
