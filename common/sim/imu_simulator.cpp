#include "sim/imu_simulator.hpp"

#include <cmath>
#include <stdexcept>

namespace liloc::sim {

void ImuConfig::validate() const {
  if (rate_hz < 50.0 || rate_hz > 2000.0) {
    throw std::invalid_argument("rate_hz must be within 50 .. 2000");
  }
  if (accel_noise_density < 0 || gyro_noise_density < 0 || accel_bias_random_walk < 0 ||
      gyro_bias_random_walk < 0 || initial_accel_bias_sigma_mps2 < 0 ||
      initial_gyro_bias_sigma_rps < 0) {
    throw std::invalid_argument("noise parameters must not be negative");
  }
}

ImuSimulator::ImuSimulator(const VehicleTrajectory& trajectory, const ImuConfig& config,
                           uint64_t seed, int64_t start_utime)
    : trajectory_(trajectory), config_(config), rng_(seed), start_utime_(start_utime) {
  config_.validate();
  accel_bias_ = gaussian(config.initial_accel_bias_sigma_mps2);
  gyro_bias_ = gaussian(config.initial_gyro_bias_sigma_rps);
  initial_accel_bias_ = accel_bias_;
  initial_gyro_bias_ = gyro_bias_;
}

Eigen::Vector3d ImuSimulator::gaussian(double sigma) {
  return Eigen::Vector3d(rng_.normal(), rng_.normal(), rng_.normal()) * sigma;
}

ImuSample ImuSimulator::next() {
  const double dt = 1.0 / config_.rate_hz;
  const double t = next_time_s();
  if (index_ > 0) {
    // Bias random walk over one sample period.
    accel_bias_ += gaussian(config_.accel_bias_random_walk * std::sqrt(dt));
    gyro_bias_ += gaussian(config_.gyro_bias_random_walk * std::sqrt(dt));
  }
  const VehicleState s = trajectory_.state(t);
  const Eigen::Matrix3d R_world_body = s.T_world_body.linear();
  const Eigen::Vector3d gravity_world(0.0, 0.0, -config_.gravity_mps2);
  ImuSample sample;
  sample.utime_us = start_utime_ + static_cast<int64_t>(std::llround(t * 1e6));
  // Discrete white noise: density * sqrt(rate).
  sample.accel_mps2 = R_world_body.transpose() * (s.acceleration_world - gravity_world) +
                      accel_bias_ + gaussian(config_.accel_noise_density / std::sqrt(dt));
  sample.gyro_rps =
      s.angular_velocity_body + gyro_bias_ + gaussian(config_.gyro_noise_density / std::sqrt(dt));
  ++index_;
  return sample;
}

}  // namespace liloc::sim
