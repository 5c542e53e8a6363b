#pragma once
// A check of the LiDAR's configured rotation on the IMU and of the LiDAR clock's offset,
// from the first seconds of motion: the IMU's gyro and accelerometer must agree with the
// motion that the LiDAR registration measured.
//
// With F the body frame as the LiDAR sees it through the configured extrinsic and B the
// IMU's, a wrong rotation R_BF != I and a wrong clock offset dt (the odometry's time of a
// pose minus the IMU time of the same instant) show as
//   gyro:  mean gyro over [t_a - dt, t_b - dt] = b_g + R_BF * (LiDAR rotation rate over [t_a, t_b])
//   accel: v(t_b) - v(t_a) = g (t_b - t_a) + integral of R_local_F(t) R_BF^T f(t - dt) dt
// with v from the registered positions. The rotation about gravity is seen only through
// the accelerations (a ground vehicle mostly turns about one axis), so both are used. The
// fit starts from the 24 axis-aligned rotations (the usual mix-ups) and keeps the best.
// No mount changes how fast the body turns: where the LiDAR's rates and the gyro's differ in
// magnitude, the LiDAR-only registration lost the motion, and the check says so instead of
// blaming the extrinsic.
//
// Pure: samples and poses in, an estimate out; the odometry warns with it.

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "imu/imu_sample.hpp"

namespace liloc {

struct ExtrinsicCheckConfig {
  bool enabled = true;
  // Motion: the registered body moving faster than this or turning faster than this.
  double min_speed_mps = 0.5;
  double min_turn_rps = 0.05;
  // The check decides after this much time since motion started, and again every
  // check_every_s up to max_window_s, as soon as the estimate is certain enough.
  double first_check_s = 10.0;
  double check_every_s = 5.0;
  double max_window_s = 30.0;
  // Velocity changes are taken over intervals of about this length.
  double interval_s = 1.0;
  // Time offsets searched, and the step.
  double max_offset_s = 0.1;
  double offset_step_s = 0.001;
  // The offset is also found in this many consecutive parts of the motion; it is named only
  // if beyond twice their spread.
  int offset_parts = 4;
  // Warn beyond these.
  double warn_rotation_deg = 3.0;
  double warn_offset_s = 0.01;
  // Residual scales (1 sigma) of a consistent rig: the registered rotation rate over a
  // sweep and the registered velocity change over an interval.
  double gyro_sigma_rps = 0.02;
  double velocity_sigma_mps = 0.1;
  template <class V>
  void visit_fields(V& v) {
    v("enabled", enabled);
    v("min_speed_mps", min_speed_mps);
    v("min_turn_rps", min_turn_rps);
    v("first_check_s", first_check_s);
    v("check_every_s", check_every_s);
    v("max_window_s", max_window_s);
    v("interval_s", interval_s);
    v("max_offset_s", max_offset_s);
    v("offset_step_s", offset_step_s);
    v("offset_parts", offset_parts);
    v("warn_rotation_deg", warn_rotation_deg);
    v("warn_offset_s", warn_offset_s);
    v("gyro_sigma_rps", gyro_sigma_rps);
    v("velocity_sigma_mps", velocity_sigma_mps);
  }
  void validate() const;
};

struct ExtrinsicEstimate {
  // Rotation from the configured LiDAR-derived body frame F into the IMU's body frame:
  // the configured R_body_lidar should be R_BF * R_body_lidar.
  Eigen::Matrix3d R_BF = Eigen::Matrix3d::Identity();
  double rotation_error_deg = 0.0;          // angle of R_BF
  double rotation_sigma_deg = 0.0;          // its 1-sigma uncertainty (largest axis)
  double time_offset_error_s = 0.0;         // add this to lidar_time_offset_s
  std::vector<double> time_offset_parts_s;  // found in each part of the motion
  double time_offset_spread_s = 0.0;        // the parts' standard deviation about it
  Eigen::Vector3d gyro_bias_rps = Eigen::Vector3d::Zero();
  double gravity_mps2 = 0.0;  // the fitted gravity's norm (9.8 if consistent)
  double gyro_rms_rps = 0.0;  // residuals at the estimate
  double velocity_rms_mps = 0.0;
  // |LiDAR rotation rate| - |gyro - bias|, rms over the sweeps: no rotation of the mount
  // changes it, so beyond noise the LiDAR registration did not follow the motion.
  double rate_magnitude_rms_rps = 0.0;
  double motion_s = 0.0;  // time in motion the estimate used
  int sweeps = 0;
  bool warn = false;  // rotation or offset beyond the warning thresholds
  std::string message;
};

class ExtrinsicCheck {
 public:
  explicit ExtrinsicCheck(const ExtrinsicCheckConfig& config);

  void add_imu(const ImuSample& sample);
  // The body pose registered from the LiDAR alone (any fixed frame) at a sweep's end.
  void add_pose(int64_t utime_us, const Eigen::Isometry3d& T_local_body);
  // Runs the estimate when one is due; returns it once, when it is certain enough or the
  // window is full. After that the check is done and keeps nothing.
  std::optional<ExtrinsicEstimate> poll(const Eigen::Matrix3d& R_body_lidar_configured,
                                        double time_offset_configured_s);
  bool done() const { return done_; }

  // The estimate from what was added so far (for tests and the poll above).
  ExtrinsicEstimate estimate() const;

 private:
  struct Pose {
    int64_t utime_us;
    Eigen::Isometry3d T;
  };
  ExtrinsicCheckConfig config_;
  std::vector<ImuSample> imu_;
  std::vector<Pose> poses_;
  int64_t motion_start_us_ = -1;
  int64_t next_check_us_ = 0;
  bool done_ = false;
};

}  // namespace liloc
