#include "sim/simulation_config.hpp"

#include <cmath>

#include "math/se3.hpp"

namespace liloc::sim {

SensorRig RigConfig::rig() const {
  const Eigen::Vector3d rpy = lidar_rpy_deg * M_PI / 180.0;
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  return {se3::make(R, lidar_translation_m), lidar_time_offset_s};
}

}  // namespace liloc::sim
