#pragma once
// Ground-vehicle motion along a route: a planar path on the right-hand lane with rounded
// corners, a speed profile limited by lateral and longitudinal acceleration, and the
// vehicle's height, pitch and roll from the terrain under its four wheels. The result is
// a C2 cubic B-spline in time of (x, y, z, yaw, pitch, roll), so velocity, acceleration
// and angular velocity are exact derivatives and a simulated IMU is consistent with the
// ground truth to numerical precision.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "sim/world.hpp"

namespace liloc::sim {

struct MotionConfig {
  double cruise_speed_mps = 7.0;
  double max_speed_mps = 10.0;
  double speed_variation = 0.25;        // cruise speed wanders by this fraction
  double max_lateral_accel_mps2 = 2.0;  // limits speed in corners
  double max_longitudinal_accel_mps2 = 1.0;
  double corner_radius_m = 7.0;
  double stationary_start_s = 3.0;  // standing still first (IMU initialization)
  double stationary_end_s = 2.0;
  double ride_height_m = 0.9;  // body (IMU) origin above the ground
  double wheelbase_m = 2.8;
  double track_m = 1.6;
  double knot_spacing_s = 0.05;

  template <class V>
  void visit_fields(V& v) {
    v("cruise_speed_mps", cruise_speed_mps);
    v("max_speed_mps", max_speed_mps);
    v("speed_variation", speed_variation);
    v("max_lateral_accel_mps2", max_lateral_accel_mps2);
    v("max_longitudinal_accel_mps2", max_longitudinal_accel_mps2);
    v("corner_radius_m", corner_radius_m);
    v("stationary_start_s", stationary_start_s);
    v("stationary_end_s", stationary_end_s);
    v("ride_height_m", ride_height_m);
    v("wheelbase_m", wheelbase_m);
    v("track_m", track_m);
    v("knot_spacing_s", knot_spacing_s);
  }
  void validate() const;
};

struct VehicleState {
  Eigen::Isometry3d T_world_body = Eigen::Isometry3d::Identity();
  Eigen::Vector3d velocity_world = Eigen::Vector3d::Zero();         // m/s
  Eigen::Vector3d acceleration_world = Eigen::Vector3d::Zero();     // m/s^2
  Eigen::Vector3d angular_velocity_body = Eigen::Vector3d::Zero();  // rad/s
};

class VehicleTrajectory {
 public:
  // waypoints: road-centre points to pass through (intersections, or any point on a road
  // for a start mid-street); the vehicle keeps lane_offset_m to the right of them.
  // Throws std::invalid_argument for fewer than two distinct waypoints.
  VehicleTrajectory(const World& world, const std::vector<Eigen::Vector2d>& waypoints,
                    const MotionConfig& config, uint64_t seed);

  // State at t seconds after the start, clamped to [0, duration_s()].
  VehicleState state(double t) const;
  Eigen::Isometry3d pose(double t) const { return state(t).T_world_body; }

  double duration_s() const { return duration_s_; }
  double length_m() const { return length_m_; }

 private:
  double knot_spacing_s_;
  double duration_s_ = 0.0;
  double length_m_ = 0.0;
  // Control points of (x, y, z, yaw, pitch, roll); point k is centred on time
  // (k - 1) * knot_spacing_s_.
  std::vector<Eigen::Matrix<double, 6, 1>> control_;
};

}  // namespace liloc::sim
