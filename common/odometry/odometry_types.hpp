#pragma once
// What the odometry produces and accepts, in core types (the process converts to and
// from messages).

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>

#include "math/se3.hpp"
#include "odometry/extrinsic_check.hpp"
#include "pointcloud/point_cloud.hpp"

namespace liloc {

// Time spent per stage on one sweep, milliseconds.
struct OdometryTimings {
  double preprocess_ms = 0.0;  // range filter, downsampling
  double propagate_ms = 0.0;   // IMU propagation or motion model, deskew
  double register_ms = 0.0;    // scan-to-map registration and state update
  double map_ms = 0.0;         // local map update
  double keyframe_ms = 0.0;    // full deskew and downsampling of a keyframe cloud
  double total_ms = 0.0;
};

struct Keyframe {
  int64_t id = 0;
  int64_t utime_us = 0;
  Eigen::Isometry3d T_odom_body = Eigen::Isometry3d::Identity();
  Eigen::Vector3d velocity_odom = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();
  Matrix6d covariance = Matrix6d::Identity();  // right perturbation (translation, rotation)
  double fitness_m = 0.0;
  bool degenerate = false;
  // Gravity's direction in the body frame (unit) and its 1-sigma angle, from the filter;
  // zero without an IMU. The map builder levels the map with it (GravityFactor).
  Eigen::Vector3d gravity_body = Eigen::Vector3d::Zero();
  double gravity_sigma_rad = 0.0;
  PointCloud cloud_body;  // deskewed to utime_us, downsampled
};

// The odometry's estimate at the end of one sweep.
struct OdometryEstimate {
  int64_t utime_us = 0;
  Eigen::Isometry3d T_odom_body = Eigen::Isometry3d::Identity();
  Eigen::Vector3d velocity_odom = Eigen::Vector3d::Zero();
  Eigen::Vector3d angular_velocity_body = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();
  // Right perturbation T = T_est Exp(d), d = (translation m, rotation rad), body frame.
  Matrix6d covariance = Matrix6d::Identity();
  bool registered = false;  // false: too few points, the pose is the prediction
  bool standing = false;    // the IMU saw the vehicle standing; velocity 0 was applied
  double fitness_m = 0.0;   // RMS point-to-plane residual
  int correspondences = 0;
  // The share of the registered points within search_inlier_m of the local map, where
  // computed: with the IMU every sweep (OdometryConfig::fit_collapse_fraction), and every
  // searched sweep; 0 elsewhere.
  double inlier_ratio = 0.0;
  bool degenerate = false;
  double translation_eigen_ratio = 0.0;
  double rotation_eigen_ratio = 0.0;
  // Not empty: the estimate is not trusted, and why (a sweep that could not be placed:
  // the pose is the prediction and the local map restarted from it; or a long degenerate
  // streak without an IMU). STATUS.odometry reports it as MODE_LOST.
  std::string lost_reason;
  // Not empty: after a restart the local map was found in the one before it and the pose
  // moved onto it (OdometryConfig::reanchor_after_s), by how much.
  std::string reanchored;
  // Not empty: this sweep's registration contradicted the IMU's prediction (a bias step, a
  // faulty or saturated IMU), which the LiDAR then outweighed
  // (OdometryConfig::imu_consistency_nis): by how much. The estimate is still trusted.
  std::string imu_disagreement;
  // Set on the first sweep that shows the LiDAR's horizon: what the odometry chose for this
  // LiDAR's elevation steps (the cut for planes seen edge-on, OdometryConfig::
  // grazing_ring_spacings or _without_imu; the range beyond which planes near level above
  // the LiDAR are left out, OdometryConfig::far_ceilings_left_out or _without_imu), and
  // from what.
  std::string ring_adaptation;
  // Set on the one estimate where the LiDAR-IMU extrinsic check decided (its message
  // says what it found; `warn` when the configuration looks wrong).
  std::optional<ExtrinsicEstimate> extrinsic_check;
  OdometryTimings timings;
  std::optional<Keyframe> keyframe;
};

// A correction from the optimizer: the state it believes the odometry had at utime_us.
struct OdometryCorrection {
  int64_t utime_us = 0;
  std::optional<Eigen::Isometry3d> T_odom_body;
  std::optional<Eigen::Vector3d> velocity_odom;
  std::optional<Eigen::Vector3d> gyro_bias;
  std::optional<Eigen::Vector3d> accel_bias;
};

struct OdometryCounters {
  int64_t scans_received = 0;
  int64_t scans_processed = 0;
  int64_t scans_out_of_order = 0;  // start before the previous sweep's end, or repeated
  int64_t scans_too_small = 0;     // fewer valid points than min_points: not registered
  int64_t scans_before_init = 0;   // dropped while waiting for IMU initialization
  int64_t scans_without_imu = 0;   // processed past the last IMU sample (IMU late or gone)
  int64_t imu_gaps = 0;            // IMU silences longer than max_sample_gap_s
  int64_t degenerate_scans = 0;
  int64_t searched_scans = 0;     // prediction beyond registration's reach: searched first
  int64_t second_guesses = 0;     // of those, searched around a second guess too (no IMU)
  int64_t map_restarts = 0;       // the local map restarted (a sweep placed nowhere, a reset)
  int64_t health_resets = 0;      // implausible speed, acceleration or jump: state reset
  int64_t imu_disagreements = 0;  // the LiDAR contradicted the IMU's prediction: widened
  int64_t reanchors = 0;          // after a restart, found again in the local map of before
  // Without an IMU: fit far worse than the sweeps before, searched again (poor_fit_factor),
  // and of those, placed elsewhere by the search.
  int64_t poor_fits_searched = 0;
  int64_t poor_fits_moved = 0;
  // Without an IMU: fit worse than the sweeps before and deskewed again, fitting better
  // (poor_fit_deskew_factor).
  int64_t poor_fits_deskewed = 0;
  // Without an IMU: after a pause, registered with the twist its own points showed
  // (own_twist_after_gap).
  int64_t own_twists_after_gaps = 0;
  // Searches accepted below search_confirmed_inlier_ratio in a young local map
  // (young_map_inserts).
  int64_t young_map_searches_accepted = 0;
  int64_t lost_scans = 0;        // estimates with a lost_reason
  int64_t standstill_scans = 0;  // zero-velocity updates applied
  int64_t keyframes = 0;
  int64_t corrections_applied = 0;
  int64_t corrections_rejected = 0;  // time outside the kept history, or non-finite
  int64_t imu_rejected = 0;          // non-finite, repeated or out-of-order samples
  int64_t scans_dropped_queue = 0;   // oldest queued sweep dropped: max_queued_scans waiting
  int64_t imu_dropped_old = 0;       // samples older than imu_buffer_s behind the newest
  int64_t scans_failed = 0;          // processing threw: the sweep was dropped (last_failure)
};

}  // namespace liloc
