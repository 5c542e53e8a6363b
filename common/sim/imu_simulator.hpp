#pragma once
// An IMU on the vehicle body: specific force and angular rate from the trajectory's exact
// derivatives, plus white noise and bias random walk (continuous-time densities, as
// in Kalibr / LIO-SAM configs; defaults are those used for NCLT's MS25).

#include <cstdint>

#include "imu/imu_sample.hpp"
#include "sim/random.hpp"
#include "sim/vehicle_trajectory.hpp"

namespace liloc::sim {

struct ImuConfig {
  double rate_hz = 200.0;
  double accel_noise_density = 3.99e-3;         // m/s^2/sqrt(Hz)
  double gyro_noise_density = 1.56e-3;          // rad/s/sqrt(Hz)
  double accel_bias_random_walk = 6.44e-5;      // m/s^3/sqrt(Hz)
  double gyro_bias_random_walk = 3.56e-5;       // rad/s^2/sqrt(Hz)
  double initial_accel_bias_sigma_mps2 = 0.05;  // turn-on bias, drawn per session
  double initial_gyro_bias_sigma_rps = 0.003;
  double gravity_mps2 = 9.81;

  template <class V>
  void visit_fields(V& v) {
    v("rate_hz", rate_hz);
    v("accel_noise_density", accel_noise_density);
    v("gyro_noise_density", gyro_noise_density);
    v("accel_bias_random_walk", accel_bias_random_walk);
    v("gyro_bias_random_walk", gyro_bias_random_walk);
    v("initial_accel_bias_sigma_mps2", initial_accel_bias_sigma_mps2);
    v("initial_gyro_bias_sigma_rps", initial_gyro_bias_sigma_rps);
    v("gravity_mps2", gravity_mps2);
  }
  void validate() const;
};

// Produces samples j = 0, 1, ... at times j / rate_hz (session time), in order.
class ImuSimulator {
 public:
  ImuSimulator(const VehicleTrajectory& trajectory, const ImuConfig& config, uint64_t seed,
               int64_t start_utime);

  ImuSample next();
  double next_time_s() const { return static_cast<double>(index_) / config_.rate_hz; }

  // Biases of the sample most recently returned.
  const Eigen::Vector3d& accel_bias() const { return accel_bias_; }
  const Eigen::Vector3d& gyro_bias() const { return gyro_bias_; }
  const Eigen::Vector3d& initial_accel_bias() const { return initial_accel_bias_; }
  const Eigen::Vector3d& initial_gyro_bias() const { return initial_gyro_bias_; }

 private:
  Eigen::Vector3d gaussian(double sigma);

  const VehicleTrajectory& trajectory_;
  ImuConfig config_;
  Random rng_;
  int64_t start_utime_;
  int64_t index_ = 0;
  Eigen::Vector3d accel_bias_;
  Eigen::Vector3d gyro_bias_;
  Eigen::Vector3d initial_accel_bias_;
  Eigen::Vector3d initial_gyro_bias_;
};

}  // namespace liloc::sim
