#pragma once
// Simulates one session: the vehicle drives its trajectory through the world while the
// IMU samples and the LiDAR sweeps, with per-point timestamps (motion distortion), range
// noise, dropouts and intensities. Output arrives in time order through callbacks, as a
// live sensor stream would.

#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <vector>

#include "imu/imu_sample.hpp"
#include "math/trajectory.hpp"
#include "pointcloud/point_cloud.hpp"
#include "sim/imu_simulator.hpp"
#include "sim/lidar_model.hpp"
#include "sim/vehicle_trajectory.hpp"
#include "sim/world.hpp"

namespace liloc::sim {

struct SensorRig {
  Eigen::Isometry3d T_body_lidar = Eigen::Isometry3d::Identity();
  double lidar_time_offset_s = 0.0;  // LiDAR clock minus IMU clock
  BeamErrorSigmas beam_errors;       // the LiDAR unit's intrinsic calibration error
};

struct SessionStats {
  int64_t sweeps = 0;
  int64_t points = 0;
  int64_t imu_samples = 0;
};

class SessionSimulator {
 public:
  SessionSimulator(const World& world, const VehicleTrajectory& trajectory, LidarSpec lidar,
                   SensorRig rig, ImuConfig imu, uint64_t seed, int64_t start_utime);

  // One sweep (deterministic in its index), in the LiDAR frame, stamped in LiDAR time.
  LidarScan simulate_sweep(int64_t index, RaycastScratch& scratch) const;

  int64_t num_sweeps() const;

  // Emits every IMU sample and sweep in order of availability: samples up to a sweep's
  // end come before it. Sweeps are ray cast on `threads` threads; the output does not
  // depend on the thread count. progress(fraction) is called after each batch.
  SessionStats run(const std::function<void(const ImuSample&)>& on_imu,
                   const std::function<void(const LidarScan&)>& on_scan,
                   const std::function<void(double)>& progress, int threads) const;

  // T_world_body sampled at rate_hz over the session, times in seconds since the epoch.
  Trajectory ground_truth(double rate_hz) const;

  const Eigen::Vector3d& initial_accel_bias() const { return initial_accel_bias_; }
  const Eigen::Vector3d& initial_gyro_bias() const { return initial_gyro_bias_; }

 private:
  const World& world_;
  const VehicleTrajectory& trajectory_;
  LidarSpec lidar_;
  SensorRig rig_;
  std::vector<BeamError> beam_errors_;  // per beam; empty for an ideal unit
  ImuConfig imu_;
  uint64_t seed_;
  int64_t start_utime_;
  Eigen::Vector3d initial_accel_bias_;
  Eigen::Vector3d initial_gyro_bias_;
};

}  // namespace liloc::sim
