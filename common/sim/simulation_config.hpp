#pragma once
// Everything that defines a simulated multi-session dataset, as one config struct
// (YAML-loadable; `liloc_sim --print-config` writes every field).

#include <Eigen/Core>
#include <cstdint>
#include <string>

#include "sim/imu_simulator.hpp"
#include "sim/session_planner.hpp"
#include "sim/session_simulator.hpp"
#include "sim/vehicle_trajectory.hpp"
#include "sim/world_generator.hpp"

namespace liloc::sim {

struct RigConfig {
  Eigen::Vector3d lidar_translation_m{0.05, 0.0, 0.35};  // LiDAR origin in the body frame
  Eigen::Vector3d lidar_rpy_deg{0.0, 0.0, 0.0};          // roll, pitch, yaw of the LiDAR
  double lidar_time_offset_s = 0.0;                      // LiDAR clock minus IMU clock
  // The LiDAR unit's intrinsic calibration error, 1 sigma per beam (0: an ideal unit).
  // Drawn once from beam_error_seed: sessions simulated with one seed share one unit.
  double beam_range_bias_sigma_m = 0.0;
  double beam_elevation_sigma_deg = 0.0;
  double beam_azimuth_sigma_deg = 0.0;
  int64_t beam_error_seed = 1;

  template <class V>
  void visit_fields(V& v) {
    v("lidar_translation_m", lidar_translation_m);
    v("lidar_rpy_deg", lidar_rpy_deg);
    v("lidar_time_offset_s", lidar_time_offset_s);
    v("beam_range_bias_sigma_m", beam_range_bias_sigma_m);
    v("beam_elevation_sigma_deg", beam_elevation_sigma_deg);
    v("beam_azimuth_sigma_deg", beam_azimuth_sigma_deg);
    v("beam_error_seed", beam_error_seed);
  }
  void validate() const;
  SensorRig rig() const;
};

struct SimulationConfig {
  WorldConfig world;
  DayChangeConfig changes;
  SessionPlanConfig sessions;
  MotionConfig motion;
  ImuConfig imu;
  RigConfig rig;
  std::string robot_id = "robot0";
  int64_t start_utime = 1748779200000000;  // 2025-06-01 12:00 UTC: session A's start
  int64_t days_between_sessions = 7;       // B, C, D start a week apart
  double ground_truth_rate_hz = 100.0;

  template <class V>
  void visit_fields(V& v) {
    v("world", world);
    v("changes", changes);
    v("sessions", sessions);
    v("motion", motion);
    v("imu", imu);
    v("rig", rig);
    v("robot_id", robot_id);
    v("start_utime", start_utime);
    v("days_between_sessions", days_between_sessions);
    v("ground_truth_rate_hz", ground_truth_rate_hz);
  }
  void validate() const;
};

}  // namespace liloc::sim
