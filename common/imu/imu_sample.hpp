#pragma once

#include <Eigen/Core>
#include <cstdint>

namespace liloc {

// One IMU measurement in the IMU (body) frame.
struct ImuSample {
  int64_t utime_us = 0;
  Eigen::Vector3d accel_mps2 = Eigen::Vector3d::Zero();  // specific force
  Eigen::Vector3d gyro_rps = Eigen::Vector3d::Zero();
};

}  // namespace liloc
