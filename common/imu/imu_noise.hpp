#pragma once

#include <stdexcept>

namespace liloc {

// An IMU's noise as continuous-time densities (as in Kalibr / LIO-SAM configs); defaults are
// those used for NCLT's MS25 IMU. The odometry's filter and the optimizer's preintegration
// both read them.
struct ImuNoiseDensities {
  double accel_noise_density = 3.99e-3;     // m/s^2/sqrt(Hz)
  double gyro_noise_density = 1.56e-3;      // rad/s/sqrt(Hz)
  double accel_bias_random_walk = 6.44e-5;  // m/s^3/sqrt(Hz)
  double gyro_bias_random_walk = 3.56e-5;   // rad/s^2/sqrt(Hz)
  double gravity_mps2 = 9.81;

  template <class V>
  void visit_fields(V& v) {
    v("accel_noise_density", accel_noise_density);
    v("gyro_noise_density", gyro_noise_density);
    v("accel_bias_random_walk", accel_bias_random_walk);
    v("gyro_bias_random_walk", gyro_bias_random_walk);
    v("gravity_mps2", gravity_mps2);
  }
  void validate() const {
    if (!(accel_noise_density > 0) || !(gyro_noise_density > 0) || !(accel_bias_random_walk >= 0) ||
        !(gyro_bias_random_walk >= 0) || !(gravity_mps2 > 0)) {
      throw std::invalid_argument(
          "IMU noise densities must be positive (bias random walks non-negative), and gravity");
    }
  }
};

}  // namespace liloc
