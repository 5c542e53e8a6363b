#include "sim/simulation_config.hpp"

#include <cmath>
#include <stdexcept>

#include "math/se3.hpp"
#include "math/so3.hpp"

namespace liloc::sim {

void RigConfig::validate() const {
  if (!lidar_translation_m.allFinite() || !lidar_rpy_deg.allFinite() ||
      !(std::abs(lidar_time_offset_s) <= 1.0)) {
    throw std::invalid_argument("the rig must be finite and lidar_time_offset_s within +-1 s");
  }
}

void SimulationConfig::validate() const {
  if (robot_id.empty() || start_utime <= 0 || days_between_sessions < 0 ||
      !(ground_truth_rate_hz > 0 && ground_truth_rate_hz <= 10000)) {
    throw std::invalid_argument(
        "robot_id must not be empty, start_utime positive, days_between_sessions not "
        "negative and ground_truth_rate_hz in (0, 10000]");
  }
}

SensorRig RigConfig::rig() const {
  return {se3::make(so3::from_rpy(lidar_rpy_deg * M_PI / 180.0), lidar_translation_m),
          lidar_time_offset_s};
}

}  // namespace liloc::sim
