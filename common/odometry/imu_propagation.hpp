#pragma once
// IMU propagation of the odometry's state and covariance (error-state transition of
// FAST-LIO2 / Sola's ESKF with right-perturbed rotation), and the motion profile it
// leaves behind for deskewing.

#include <cstdint>
#include <vector>

#include "imu/imu_noise.hpp"
#include "imu/imu_sample.hpp"
#include "odometry/motion_profile.hpp"
#include "odometry/navigation_state.hpp"

namespace liloc {

struct ImuNoiseConfig : ImuNoiseDensities {
  // The local map's "up" can drift slowly from gravity's (tilt errors baked into the
  // map); a small random walk of the gravity direction lets the filter follow it instead
  // of blaming the accelerometer bias.
  double gravity_direction_random_walk = 1e-4;  // rad/sqrt(s)
  double max_sample_gap_s = 0.05;               // a longer silence between samples is an IMU gap
  // Across a gap (or past the last sample) the motion is interpolated, and what the
  // vehicle really did is unknown: its acceleration and rate are taken to wander by
  // these densities (a car's manoeuvres, not the sensor's noise).
  double gap_accel_density = 1.0;  // m/s^2/sqrt(s)
  double gap_gyro_density = 0.2;   // rad/s/sqrt(s)

  template <class V>
  void visit_fields(V& v) {
    ImuNoiseDensities::visit_fields(v);
    v("gravity_direction_random_walk", gravity_direction_random_walk);
    v("max_sample_gap_s", max_sample_gap_s);
    v("gap_accel_density", gap_accel_density);
    v("gap_gyro_density", gap_gyro_density);
  }
  void validate() const;
};

struct PropagationStats {
  int gaps = 0;               // sample spacings longer than max_sample_gap_s
  double extrapolated_s = 0;  // time propagated beyond the last sample
};

// Propagates x and P from t_from to t_to. `samples` must hold the last sample at or
// before t_from and may end before t_to (then the last sample is held). Over gaps the
// process noise grows with the gap, so the filter trusts the LiDAR more. Appends the
// motion to `motion` when given.
PropagationStats propagate(NavState& x, StateMatrix& P, int64_t t_from, int64_t t_to,
                           const std::vector<ImuSample>& samples, const ImuNoiseConfig& noise,
                           MotionProfile* motion);

}  // namespace liloc
