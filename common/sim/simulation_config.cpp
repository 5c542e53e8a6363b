#include "sim/simulation_config.hpp"

#include <cmath>

#include "math/se3.hpp"
#include "math/so3.hpp"

namespace liloc::sim {

SensorRig RigConfig::rig() const {
  return {se3::make(so3::from_rpy(lidar_rpy_deg * M_PI / 180.0), lidar_translation_m),
          lidar_time_offset_s};
}

}  // namespace liloc::sim
