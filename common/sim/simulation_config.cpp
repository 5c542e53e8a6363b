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
  // Beyond these a unit is broken, not miscalibrated.
  if (!(beam_range_bias_sigma_m >= 0 && beam_range_bias_sigma_m <= 0.5) ||
      !(beam_elevation_sigma_deg >= 0 && beam_elevation_sigma_deg <= 2.0) ||
      !(beam_azimuth_sigma_deg >= 0 && beam_azimuth_sigma_deg <= 2.0)) {
    throw std::invalid_argument(
        "rig: beam_range_bias_sigma_m must be in [0, 0.5] and beam_elevation_sigma_deg, "
        "beam_azimuth_sigma_deg in [0, 2]");
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
  SensorRig rig;
  rig.T_body_lidar = se3::make(so3::from_rpy(lidar_rpy_deg * M_PI / 180.0), lidar_translation_m);
  rig.lidar_time_offset_s = lidar_time_offset_s;
  rig.beam_errors.range_bias_m = beam_range_bias_sigma_m;
  rig.beam_errors.elevation_rad = beam_elevation_sigma_deg * M_PI / 180.0;
  rig.beam_errors.azimuth_rad = beam_azimuth_sigma_deg * M_PI / 180.0;
  rig.beam_errors.seed = static_cast<uint64_t>(beam_error_seed);
  return rig;
}

}  // namespace liloc::sim
