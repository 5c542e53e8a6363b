#include "odometry/lidar_inertial_odometry.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include "math/so3.hpp"
#include "math/stopwatch.hpp"
#include "odometry/require_positive.hpp"
#include "odometry/scan_deskewer.hpp"
#include "odometry/search_answer.hpp"
#include "pointcloud/elevation_gap.hpp"
#include "pointcloud/voxel_grid.hpp"
#include "pointcloud/voxel_index_table.hpp"

namespace liloc {
namespace {

int64_t to_us(double s) { return static_cast<int64_t>(std::llround(s * 1e6)); }

// The pose's spread where the local map begins: its frame is defined there.
constexpr double kOriginRotationSigmaRad = 3e-3;
constexpr double kOriginPositionSigmaM = 1e-3;

// Runs one step of the sweep's pipeline and sets `ms` to its wall time.
template <class Step>
decltype(auto) timed(double& ms, Step&& step) {
  const Stopwatch watch;
  if constexpr (std::is_void_v<decltype(step())>) {
    step();
    ms = watch.ms();
  } else {
    decltype(auto) out = step();
    ms = watch.ms();
    return out;
  }
}

// The upper median (values reordered).
template <class T>
T median(std::vector<T>& values) {
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

// One point per voxel (the first, so that it keeps its own time).
std::vector<LidarPoint> first_per_voxel(const std::vector<LidarPoint>& points, float voxel_m) {
  VoxelIndexTable seen(points.size() / 4 + 1);
  std::vector<LidarPoint> out;
  out.reserve(points.size() / 4);
  for (const LidarPoint& p : points) {
    if (seen.insert(voxel_key(voxel_index(p.position_m, voxel_m))).second) {
      out.push_back(p);
    }
  }
  return out;
}

}  // namespace

void OdometryConfig::validate() const {
  imu.validate();
  map.validate();
  registration.validate();
  if (!(min_range_m >= 0) || !(max_range_m > min_range_m)) {
    throw std::invalid_argument("need 0 <= min_range_m < max_range_m");
  }
  if (!(registration_voxel_m > 0) || !(keyframe_voxel_m > 0) || min_points < 1 ||
      max_registration_points < 6) {
    throw std::invalid_argument("voxel sizes must be positive and min_points at least 1");
  }
  if (!(keyframe_translation_m > 0) || !(keyframe_rotation_rad > 0)) {
    throw std::invalid_argument("keyframe thresholds must be positive");
  }
  if (!(init_window_s > 0) || !(imu_wait_s >= 0) || !(history_s > 0)) {
    throw std::invalid_argument("init_window_s and history_s must be positive");
  }
  if (max_queued_scans < 1 || !(imu_buffer_s >= 1.0 && imu_buffer_s <= 600.0)) {
    throw std::invalid_argument(
        "max_queued_scans must be at least 1 and imu_buffer_s within [1, 600]");
  }
  if (uncertain_iterations < 1 || search_confirming_starts < 1) {
    throw std::invalid_argument(
        "uncertain_iterations and search_confirming_starts must be at least 1");
  }
  if (!(search_tie_fraction > 0 && search_tie_fraction <= 1) || !(search_tie_odds >= 1)) {
    throw std::invalid_argument(
        "search_tie_fraction must be in (0, 1] (1: only equal counts tie) and search_tie_odds at "
        "least 1");
  }
  if (young_map_inserts < 0) {
    throw std::invalid_argument("young_map_inserts must be at least 0 (0: no young-map floor)");
  }
  if (!(second_guess_window_s >= 0)) {
    throw std::invalid_argument("second_guess_window_s must be at least 0 (0: one guess)");
  }
  if (reanchor_attempts < 0) {
    throw std::invalid_argument("reanchor_attempts must be at least 0 (0: never)");
  }
  if (!(poor_fit_factor >= 0) || !(poor_fit_floor_m >= 0) || poor_fit_window < 2 ||
      !(poor_fit_deskew_factor >= 1) || !(poor_fit_deskew_floor_m >= 0) ||
      poor_fit_deskew_passes < 0) {
    throw std::invalid_argument(
        "poor_fit_factor (0: never), poor_fit_floor_m, poor_fit_deskew_floor_m and "
        "poor_fit_deskew_passes must be at least 0, poor_fit_deskew_factor at least 1, "
        "poor_fit_window at least 2");
  }
  if (!(poor_fit_deskew_min_gain >= 0 && poor_fit_deskew_min_gain < 1)) {
    throw std::invalid_argument("poor_fit_deskew_min_gain must be in [0, 1)");
  }
  if (!(imu_consistency_nis >= 0) || imu_distrust_doublings < 0) {
    throw std::invalid_argument(
        "imu_consistency_nis (0: no check) and imu_distrust_doublings must be at least 0");
  }
  if (!(own_motion_inlier_gain >= 1) ||
      !(fit_collapse_fraction >= 0 && fit_collapse_fraction < 1)) {
    throw std::invalid_argument(
        "own_motion_inlier_gain must be at least 1 and fit_collapse_fraction in [0, 1) (0: no "
        "collapse check)");
  }
  if (weak_fit_correspondences < 0 || !(weak_fit_inlier_ratio >= 0 && weak_fit_inlier_ratio < 1)) {
    throw std::invalid_argument(
        "weak_fit_correspondences must be at least 0 and weak_fit_inlier_ratio in [0, 1) (0: "
        "no check)");
  }
  if (!(imu_fault_window_s >= 0) || !(imu_fault_fraction > 0 && imu_fault_fraction <= 1)) {
    throw std::invalid_argument(
        "imu_fault_window_s must be at least 0 (0: no check) and imu_fault_fraction in (0, 1]");
  }
  if (!(imu_fault_gyro_bias_sigma_rps >= 0)) {
    throw std::invalid_argument("imu_fault_gyro_bias_sigma_rps must be at least 0 (0: kept)");
  }
  if (!(grazing_ring_spacings >= 0) || !(grazing_ring_spacings_without_imu >= 0) ||
      !(min_incidence_cos_floor >= 0 &&
        min_incidence_cos_floor <= registration.min_incidence_cos)) {
    throw std::invalid_argument(
        "grazing_ring_spacings and grazing_ring_spacings_without_imu must be at least 0 (0: the "
        "cut as configured) and min_incidence_cos_floor in [0, registration.min_incidence_cos]");
  }
  search.validate();
  extrinsic_check.validate();
  if (!(correction_blend > 0 && correction_blend <= 1)) {
    throw std::invalid_argument("correction_blend must be in (0, 1]");
  }
  if (!(redeskew_blend >= 0 && redeskew_blend <= 1)) {
    throw std::invalid_argument("redeskew_blend must be in [0, 1]");
  }
  require_positive({{"stationary_accel_std_mps2", stationary_accel_std_mps2},
                    {"stationary_gyro_std_rps", stationary_gyro_std_rps},
                    {"standstill_max_speed_mps", standstill_max_speed_mps},
                    {"standstill_gyro_rps", standstill_gyro_rps},
                    {"standstill_accel_std_mps2", standstill_accel_std_mps2},
                    {"standstill_velocity_sigma_mps", standstill_velocity_sigma_mps},
                    {"motion_translation_sigma_mps", motion_translation_sigma_mps},
                    {"motion_rotation_sigma_rps", motion_rotation_sigma_rps},
                    {"own_twist_vertical_sigma_mps", own_twist_vertical_sigma_mps},
                    {"own_twist_tilt_rate_sigma_rps", own_twist_tilt_rate_sigma_rps},
                    {"max_rotation_extrapolation_s", max_rotation_extrapolation_s},
                    {"long_gap_s", long_gap_s},
                    {"long_gap_search_m", long_gap_search_m},
                    {"correspondence_sigmas", correspondence_sigmas},
                    {"correspondence_lever_m", correspondence_lever_m},
                    {"correspondence_cap_m", correspondence_cap_m},
                    {"kernel_fraction", kernel_fraction},
                    {"search_beyond_m", search_beyond_m},
                    {"search_max_xy_m", search_max_xy_m},
                    {"search_max_yaw_rad", search_max_yaw_rad},
                    {"search_max_z_m", search_max_z_m},
                    {"search_inlier_m", search_inlier_m},
                    {"search_min_inlier_ratio", search_min_inlier_ratio},
                    {"search_confirmed_inlier_ratio", search_confirmed_inlier_ratio},
                    {"search_agree_m", search_agree_m},
                    {"search_agree_rad", search_agree_rad},
                    {"search_runner_up_fraction", search_runner_up_fraction},
                    {"young_map_confirmed_inlier_ratio", young_map_confirmed_inlier_ratio},
                    {"search_settle_after_s", search_settle_after_s},
                    {"poor_fit_search_m", poor_fit_search_m},
                    {"poor_fit_search_yaw_rad", poor_fit_search_yaw_rad},
                    {"reanchor_after_s", reanchor_after_s},
                    {"lost_after_degenerate_s", lost_after_degenerate_s},
                    {"imu_distrust_accel_mps2", imu_distrust_accel_mps2},
                    {"imu_distrust_gyro_rps", imu_distrust_gyro_rps},
                    {"imu_distrust_settled_m", imu_distrust_settled_m},
                    {"imu_distrust_settled_rad", imu_distrust_settled_rad},
                    {"imu_distrust_hold_s", imu_distrust_hold_s},
                    {"max_speed_mps", max_speed_mps},
                    {"max_accel_mps2", max_accel_mps2},
                    {"max_jump_m", max_jump_m},
                    {"weak_fit_window_s", weak_fit_window_s},
                    {"correction_max_step_m", correction_max_step_m},
                    {"correction_max_step_rad", correction_max_step_rad},
                    {"map_insert_translation_m", map_insert_translation_m},
                    {"map_insert_rotation_rad", map_insert_rotation_rad}});
  if (!lidar_translation_m.allFinite() || !lidar_rpy_deg.allFinite() ||
      !(std::abs(lidar_time_offset_s) <= 1.0)) {
    throw std::invalid_argument(
        "the LiDAR extrinsic must be finite and lidar_time_offset_s within +-1 s");
  }
}

Eigen::Isometry3d OdometryConfig::T_body_lidar() const {
  return se3::make(so3::from_rpy(lidar_rpy_deg * M_PI / 180.0), lidar_translation_m);
}

LidarInertialOdometry::LidarInertialOdometry(const OdometryConfig& config)
    : config_(config), T_body_lidar_(config.T_body_lidar()), map_(config.map) {
  config_.validate();
  if (config_.use_imu && config_.extrinsic_check.enabled) {
    extrinsic_check_.emplace(config_.extrinsic_check);
    OdometryConfig lidar_only = config_;
    lidar_only.use_imu = false;
    lidar_only.redeskew_blend = 1.0;  // see OdometryConfig::redeskew_blend
    lidar_only_ = std::make_unique<LidarInertialOdometry>(lidar_only);
  }
}

const OdometryCounters& LidarInertialOdometry::counters() const {
  const ImuBuffer::Counters& imu = imu_.counters();
  counters_.imu_rejected = imu.non_finite + imu.duplicate + imu.out_of_order;
  return counters_;
}

void LidarInertialOdometry::add_imu(const ImuSample& sample) {
  if (!config_.use_imu) {
    return;
  }
  if (imu_.add(sample) == ImuBuffer::AddResult::kAccepted && lidar_only_) {
    extrinsic_check_->add_imu(sample);
  }
  const size_t before = imu_.size();
  imu_.drop_before(imu_.last_utime() - to_us(config_.imu_buffer_s));
  counters_.imu_dropped_old += static_cast<int64_t>(before - imu_.size());
}

void LidarInertialOdometry::add_scan(LidarScan scan) {
  ++counters_.scans_received;
  const int64_t start = scan.utime_us - to_us(config_.lidar_time_offset_s);
  const int64_t previous_end = scans_.empty()
                                   ? last_scan_end_utime_
                                   : scans_.back().utime_us - to_us(config_.lidar_time_offset_s) +
                                         to_us(scans_.back().scan_period_s);
  // A sweep may start up to 1 ms before the previous one's nominal end (clock jitter).
  if (previous_end != 0 && start < previous_end - 1000) {
    ++counters_.scans_out_of_order;
    return;
  }
  scans_.push_back(std::move(scan));
  if (scans_.size() > static_cast<size_t>(config_.max_queued_scans)) {
    scans_.pop_front();
    ++counters_.scans_dropped_queue;
  }
}

std::vector<OdometryEstimate> LidarInertialOdometry::process() { return run(false); }

std::vector<OdometryEstimate> LidarInertialOdometry::flush() { return run(true); }

std::vector<OdometryEstimate> LidarInertialOdometry::run(bool force) {
  std::vector<OdometryEstimate> out;
  const int64_t offset_us = to_us(config_.lidar_time_offset_s);
  while (!scans_.empty()) {
    const LidarScan& scan = scans_.front();
    const int64_t start = scan.utime_us - offset_us;
    const int64_t end = start + to_us(scan.scan_period_s);
    const int64_t newest_end =
        scans_.back().utime_us - offset_us + to_us(scans_.back().scan_period_s);
    const bool waited_enough = force || newest_end - end >= to_us(config_.imu_wait_s);
    if (config_.use_imu) {
      if (!initialized_) {
        if (imu_.empty() || imu_.last_utime() < start) {
          if (!waited_enough) {
            break;
          }
          ++counters_.scans_before_init;
          scans_.pop_front();
          continue;
        }
        if (!initialize(start)) {
          ++counters_.scans_before_init;
          scans_.pop_front();
          continue;
        }
      } else if (imu_.last_utime() < end) {
        if (!waited_enough) {
          break;
        }
        ++counters_.scans_without_imu;
      }
    } else if (!initialized_) {
      initialized_ = true;
      state_utime_ = start;
      P_.setZero();
    }
    if (lidar_only_) {
      lidar_only_->add_scan(scan);
      // Deskewed twice (the second time with its own twist), a LiDAR-only pose stands for
      // its sweep's end: over 1 s rotation intervals the check finds 0-4 ms on correct
      // rigs (a quarter sweep taken off, as per-pair rates had suggested, read as 25-29 ms).
      for (const OdometryEstimate& e : lidar_only_->process()) {
        if (e.registered && e.lost_reason.empty()) {
          extrinsic_check_->add_pose(e.utime_us, e.T_odom_body);
        }
      }
    }
    try {
      out.push_back(process_scan(scan, start, end));
    } catch (const std::exception& e) {
      // The state is left as the step that threw found it; the sweep is lost, not the
      // odometry (nothing after it may wait behind it).
      ++counters_.scans_failed;
      last_failure_ = e.what();
    }
    last_scan_end_utime_ = end;
    scans_.pop_front();
  }
  return out;
}

bool LidarInertialOdometry::initialize(int64_t start_utime) {
  const int64_t window_start = start_utime - to_us(config_.init_window_s);
  if (imu_.first_utime() > window_start) {
    return false;  // the IMU started too late to see gravity before this sweep
  }
  const std::vector<ImuSample> window = imu_.between(window_start, start_utime);
  Eigen::Vector3d mean_acc = Eigen::Vector3d::Zero(), mean_gyro = Eigen::Vector3d::Zero();
  for (const ImuSample& s : window) {
    mean_acc += s.accel_mps2;
    mean_gyro += s.gyro_rps;
  }
  const double n = static_cast<double>(window.size());
  mean_acc /= n;
  mean_gyro /= n;
  double var_acc = 0.0, var_gyro = 0.0;
  for (const ImuSample& s : window) {
    var_acc += (s.accel_mps2 - mean_acc).squaredNorm() / n;
    var_gyro += (s.gyro_rps - mean_gyro).squaredNorm() / n;
  }
  const bool standing = std::sqrt(var_acc) < config_.stationary_accel_std_mps2 &&
                        std::sqrt(var_gyro) < config_.stationary_gyro_std_rps;
  // Level the body: the mean specific force points up. Yaw stays 0 (it defines odom).
  x_ = NavState{};
  x_.R = Eigen::Quaterniond::FromTwoVectors(mean_acc, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  x_.g = Eigen::Vector3d(0, 0, -config_.imu.gravity_mps2);
  x_.bg = standing ? mean_gyro : Eigen::Vector3d::Zero();
  StateVector sigma;
  sigma.segment<3>(kRot).setConstant(kOriginRotationSigmaRad);
  sigma.segment<3>(kPos).setConstant(kOriginPositionSigmaM);
  sigma.segment<3>(kVel).setConstant(standing ? 0.01 : 2.0);
  sigma.segment<3>(kBg).setConstant(standing ? 2e-3 : 1e-2);
  sigma.segment<3>(kBa).setConstant(0.1);
  sigma.segment<2>(kGrav).setConstant(0.01);
  P_ = sigma.cwiseAbs2().asDiagonal();
  state_utime_ = start_utime;
  initialized_ = true;
  return true;
}

Eigen::Isometry3d LidarInertialOdometry::T_local_body() const { return se3::make(x_.R, x_.p); }

void LidarInertialOdometry::set_T_local_body(const Eigen::Isometry3d& T_local_body) {
  x_.R = T_local_body.linear();
  x_.p = T_local_body.translation();
}

MotionProfile LidarInertialOdometry::constant_twist_motion(const Eigen::Isometry3d& T_start,
                                                           int64_t t0_us, int64_t t1_us,
                                                           const Vector6d& twist) {
  const double dt = (t1_us - t0_us) * 1e-6;
  const Eigen::Vector3d omega = twist.tail<3>();
  const Eigen::Vector3d v_local = T_start.linear() * twist.head<3>();
  const Eigen::Matrix3d R_end = so3::normalize(T_start.linear() * so3::exp(omega * dt));
  MotionProfile motion;
  motion.add(
      {t0_us, T_start.linear(), T_start.translation(), v_local, omega, Eigen::Vector3d::Zero()});
  motion.add({t1_us, R_end, T_start.translation() + v_local * dt, R_end * twist.head<3>(), omega,
              Eigen::Vector3d::Zero()});
  return motion;
}

Vector6d LidarInertialOdometry::twist_to(const Sweep& sweep,
                                         const Eigen::Isometry3d& T_local_body) {
  // The velocity over the time since the previous sweep's end, which the prediction
  // covered: not the sweep's own duration (scans spaced irregularly, dropped sweeps).
  const Eigen::Isometry3d& T_prev = sweep.T_local_body_before;
  const double dt = std::max(sweep.gap_s(), 1e-3);
  Vector6d twist;
  twist.head<3>() =
      T_prev.linear().transpose() * (T_local_body.translation() - T_prev.translation()) / dt;
  twist.tail<3>() = so3::log(T_prev.linear().transpose() * T_local_body.linear()) / dt;
  return twist;
}

LidarInertialOdometry::Deskewed LidarInertialOdometry::deskew_at_twist(
    const Sweep& sweep, const Vector6d& twist) const {
  Deskewed out;
  out.motion =
      constant_twist_motion(sweep.T_local_body_before, sweep.utime_before, sweep.end_utime, twist);
  out.points_body =
      deskew(sweep.sparse, sweep.start_utime, sweep.end_utime, out.motion, T_body_lidar_);
  return out;
}

Vector6d LidarInertialOdometry::measured_twist(const Sweep& sweep) const {
  return twist_to(sweep, T_local_body());
}

void LidarInertialOdometry::update_twist(const Sweep& sweep) {
  // After a pause, the twist since the previous sweep is an average over the pause.
  twist_ = sweep.own_twist ? *sweep.own_twist : measured_twist(sweep);
  x_.v = x_.R * twist_.head<3>();
}

std::optional<Eigen::Vector3d> LidarInertialOdometry::average_body_velocity() const {
  // Body-frame steps: a vehicle driving on through a turn keeps its body-frame velocity,
  // and the average does not cut the turn's corner.
  const int64_t since = state_utime_ - to_us(config_.second_guess_window_s);
  auto first = std::lower_bound(history_.begin(), history_.end(), since,
                                [](const HistoryEntry& e, int64_t t) { return e.utime_us < t; });
  if (first == history_.end() || std::next(first) == history_.end()) {
    return std::nullopt;
  }
  Eigen::Vector3d moved_body = Eigen::Vector3d::Zero();
  for (auto a = first, b = std::next(first); b != history_.end(); ++a, ++b) {
    moved_body += a->T_local_body.linear().transpose() *
                  (b->T_local_body.translation() - a->T_local_body.translation());
  }
  return moved_body / ((history_.back().utime_us - first->utime_us) * 1e-6);
}

void LidarInertialOdometry::predict(Sweep& sweep) {
  const int64_t end_utime = sweep.end_utime;
  if (config_.use_imu) {
    const PropagationStats stats =
        propagate(x_, P_, state_utime_, end_utime, imu_.between(state_utime_, end_utime),
                  config_.imu, &sweep.motion);
    counters_.imu_gaps += stats.gaps;
    last_omega_ = sweep.motion.samples().back().omega_body;
  } else {
    const double dt = (end_utime - state_utime_) * 1e-6;
    Vector6d twist = twist_;
    if (dt > config_.max_rotation_extrapolation_s) {
      // Only the heading turns on (about the local frame's z), and for a while only.
      const double yaw_rate = (x_.R * twist_.tail<3>()).z();
      twist.tail<3>() = x_.R.transpose() * Eigen::Vector3d(0.0, 0.0, yaw_rate) *
                        (config_.max_rotation_extrapolation_s / dt);
      if (config_.second_guess_window_s > 0.0) {
        if (const std::optional<Eigen::Vector3d> v_body = average_body_velocity()) {
          Vector6d averaged = twist;
          averaged.head<3>() = *v_body;
          const MotionSample end =
              constant_twist_motion(T_local_body(), state_utime_, end_utime, averaged)
                  .samples()
                  .back();
          sweep.T_local_body_second_guess = se3::make(end.R, end.p);
        }
      }
    }
    sweep.motion = constant_twist_motion(T_local_body(), state_utime_, end_utime, twist);
    const MotionSample& end = sweep.motion.samples().back();
    x_.R = end.R;
    x_.p = end.p;
    x_.v = end.v;
    P_.topLeftCorner<6, 6>().diagonal() += constant_velocity_variance(dt);
    last_omega_ = twist_.tail<3>();
  }
  state_utime_ = end_utime;
}

std::vector<Eigen::Vector3f> LidarInertialOdometry::registration_points(
    const std::vector<Eigen::Vector3f>& points) const {
  return evenly_spaced(points, static_cast<size_t>(config_.max_registration_points));
}

Vector6d LidarInertialOdometry::constant_velocity_variance(double dt_s) const {
  Vector6d variance;
  variance.segment<3>(kPos).setConstant(std::pow(config_.motion_translation_sigma_mps * dt_s, 2));
  variance.segment<3>(kRot).setConstant(std::pow(config_.motion_rotation_sigma_rps * dt_s, 2));
  return variance;
}

double LidarInertialOdometry::prediction_reach_m() const {
  return reach_of(P_.topLeftCorner<6, 6>());
}

double LidarInertialOdometry::reach_of(const Matrix6d& pose_covariance) const {
  const double sigma_p = std::sqrt(pose_covariance.diagonal().segment<3>(kPos).maxCoeff());
  const double sigma_r = std::sqrt(pose_covariance.diagonal().segment<3>(kRot).maxCoeff());
  return config_.correspondence_sigmas * (sigma_p + sigma_r * config_.correspondence_lever_m);
}

RegistrationConfig LidarInertialOdometry::registration_config(double radius_m) const {
  RegistrationConfig out = config_.registration;
  out.max_correspondence_m = std::max(radius_m, config_.registration.max_correspondence_m);
  if (out.max_correspondence_m > config_.registration.max_correspondence_m) {
    out.cauchy_scale_m =
        std::max(out.cauchy_scale_m, config_.kernel_fraction * out.max_correspondence_m);
    out.max_iterations = std::max(out.max_iterations, config_.uncertain_iterations);
    out.max_associations = std::max(out.max_associations, config_.uncertain_iterations);
    // A start this uncertain puts a thin wall's other face anywhere near the plane: only
    // the views tell the faces apart.
    out.back_face_min_offset_m = 0.0;
  }
  return out;
}

bool LidarInertialOdometry::standing_still(int64_t t0_us, int64_t t1_us) const {
  // A vehicle cruising straight on a smooth road has the same IMU signature as one that
  // stands, so the filter must already believe it is (nearly) standing.
  if (x_.v.norm() > config_.standstill_max_speed_mps) {
    return false;
  }
  const std::vector<ImuSample> samples = imu_.between(t0_us, t1_us);
  const double duration_s = (t1_us - t0_us) * 1e-6;
  if (samples.size() < 5 || duration_s <= 0) {
    return false;
  }
  const double n = static_cast<double>(samples.size());
  Eigen::Vector3d mean_gyro = Eigen::Vector3d::Zero();
  Eigen::Vector3d mean_acc = Eigen::Vector3d::Zero();
  for (const ImuSample& s : samples) {
    mean_gyro += s.gyro_rps / n;
    mean_acc += s.accel_mps2 / n;
  }
  double acc_variance = 0.0;  // per axis
  for (const ImuSample& s : samples) {
    acc_variance += (s.accel_mps2 - mean_acc).squaredNorm() / (3.0 * n);
  }
  // Thresholds above the white noise that the IMU's own density predicts at its rate.
  const double rate_hz = n / duration_s;
  const double gyro_mean_noise = config_.imu.gyro_noise_density * std::sqrt(rate_hz / n);
  const double acc_sample_noise = config_.imu.accel_noise_density * std::sqrt(rate_hz);
  return (mean_gyro - x_.bg).norm() < config_.standstill_gyro_rps + 3.0 * gyro_mean_noise &&
         std::sqrt(acc_variance) < config_.standstill_accel_std_mps2 + 2.0 * acc_sample_noise;
}

void LidarInertialOdometry::zero_velocity_update() {
  // Kalman update with z = 0 - v, H selecting the velocity.
  const Eigen::Matrix3d S =
      P_.block<3, 3>(kVel, kVel) +
      Eigen::Matrix3d::Identity() * std::pow(config_.standstill_velocity_sigma_mps, 2);
  const Eigen::Matrix<double, kStateDim, 3> K = P_.middleCols<3>(kVel) * S.inverse();
  x_ = boxplus(x_, K * (-x_.v));
  P_ -= K * P_.middleRows<3>(kVel);
  P_ = 0.5 * (P_ + P_.transpose());
}

void LidarInertialOdometry::update(const RegistrationResult& result, bool update_biases) {
  // The registration solved for the pose with the filter's pose marginal as prior. The
  // other states follow through their correlation with the pose, and the covariance
  // takes the LiDAR information: the iterated-EKF update, done on the pose block (both
  // in the right perturbation of math/se3.hpp).
  const Vector6d d_pose = se3::minus(result.T_target_source, T_local_body());
  const Matrix6d P_pp = P_.topLeftCorner<6, 6>();
  const Matrix6d P_pp_inv = P_pp.inverse();
  const Matrix6d posterior = (P_pp_inv + result.information).inverse();
  if (config_.use_imu) {
    Eigen::Matrix<double, kStateDim, 6> A = P_.leftCols<6>() * P_pp_inv;
    StateMatrix reduction = A * (P_pp - posterior) * A.transpose();
    if (!update_biases) {
      // Schmidt-Kalman: the considered states neither move nor shrink; their correlations
      // with the others are updated as in the full update.
      constexpr int kConsidered = kStateDim - kBg;
      A.bottomRows<kConsidered>().setZero();
      reduction.bottomRightCorner<kConsidered, kConsidered>().setZero();
    }
    x_ = boxplus(x_, A * d_pose);
    P_ -= reduction;
    P_ = 0.5 * (P_ + P_.transpose());
  } else {
    set_T_local_body(result.T_target_source);
    P_.topLeftCorner<6, 6>() = posterior;
  }
}

OdometryEstimate LidarInertialOdometry::process_scan(const LidarScan& scan, int64_t start_utime,
                                                     int64_t end_utime) {
  const Stopwatch watch;
  OdometryEstimate est;
  est.utime_us = end_utime;
  Sweep sweep =
      timed(est.timings.preprocess_ms, [&] { return preprocess(scan, start_utime, end_utime); });
  timed(est.timings.propagate_ms, [&] { predict_and_deskew(sweep, est); });
  if (static_cast<int>(sweep.valid.size()) >= config_.min_points) {
    if (!adapted_to_rings_) {
      est.ring_adaptation = adapt_to_rings(scan);
    }
    timed(est.timings.register_ms, [&] { register_sweep(sweep, est); });
    last_registered_utime_ = end_utime;
    timed(est.timings.map_ms, [&] {
      update_map(sweep);
      reanchor(est);
    });
    est.keyframe = timed(est.timings.keyframe_ms, [&] { return make_keyframe(sweep); });
  } else {
    ++counters_.scans_too_small;
  }
  finish_estimate(est);
  est.timings.total_ms = watch.ms();
  return est;
}

std::string LidarInertialOdometry::adapt_to_rings(const LidarScan& scan) {
  const double spacings =
      config_.use_imu ? config_.grazing_ring_spacings : config_.grazing_ring_spacings_without_imu;
  const bool ceilings_left_out =
      config_.use_imu ? config_.far_ceilings_left_out : config_.far_ceilings_left_out_without_imu;
  if (spacings <= 0.0 && !ceilings_left_out) {
    adapted_to_rings_ = true;
    return {};
  }
  // Until a sweep shows enough of the horizon (a blocked or empty first view), the
  // configured cut holds: the safe one for a LiDAR of sparse rings.
  const std::optional<double> step_rad = largest_elevation_gap_rad(scan.points);
  if (!step_rad) {
    return {};
  }
  adapted_to_rings_ = true;
  // Each piece formatted on its own and appended: no offsets into one fixed buffer.
  std::string text;
  const auto append = [&text](const char* format, auto... args) {
    char piece[160];
    std::snprintf(piece, sizeof(piece), format, args...);
    text += piece;
  };
  append("elevation steps of up to %.2f deg near the LiDAR's horizon", *step_rad * so3::kRadToDeg);
  if (spacings > 0.0) {
    double& cut = config_.registration.min_incidence_cos;
    cut = std::min(cut, std::max(config_.min_incidence_cos_floor, std::sin(spacings * *step_rad)));
    append(": planes seen at a cosine of incidence below %.3f are left out", cut);
  }
  // Beyond the range where those steps open wider than an association radius, the map holds
  // a ceiling as one ring of successive sweeps (far_ceilings_left_out, or _without_imu).
  const double far_m = config_.registration.max_correspondence_m / *step_rad;
  if (ceilings_left_out && far_m < config_.max_range_m) {
    config_.registration.far_ceiling_beyond_m = far_m;
    append("%s planes near level above the LiDAR beyond %.1f m are left out",
           spacings > 0.0 ? ";" : ":", far_m);
  }
  return text;
}

LidarInertialOdometry::Sweep LidarInertialOdometry::preprocess(const LidarScan& scan,
                                                               int64_t start_utime,
                                                               int64_t end_utime) const {
  // The vehicle itself and far returns out, one point per voxel.
  Sweep sweep;
  sweep.start_utime = start_utime;
  sweep.end_utime = end_utime;
  sweep.valid.reserve(scan.points.size());
  const float min_sq = static_cast<float>(config_.min_range_m * config_.min_range_m);
  const float max_sq = static_cast<float>(config_.max_range_m * config_.max_range_m);
  for (const LidarPoint& p : scan.points) {
    const float r2 = p.position_m.squaredNorm();
    if (r2 >= min_sq && r2 <= max_sq) {
      sweep.valid.push_back(p);
    }
  }
  sweep.sparse = first_per_voxel(sweep.valid, static_cast<float>(config_.registration_voxel_m));
  return sweep;
}

void LidarInertialOdometry::predict_and_deskew(Sweep& sweep, OdometryEstimate& est) {
  sweep.T_local_body_before = T_local_body();
  sweep.velocity_before = x_.v;
  sweep.utime_before = state_utime_;
  sweep.registered_before_utime = last_registered_utime_;
  predict(sweep);
  if (config_.use_imu && config_.zero_velocity_update &&
      standing_still(sweep.start_utime, sweep.end_utime)) {
    zero_velocity_update();
    est.standing = true;
    ++counters_.standstill_scans;
  }
  sweep.points_body =
      deskew(sweep.sparse, sweep.start_utime, sweep.end_utime, sweep.motion, T_body_lidar_);
}

void LidarInertialOdometry::register_sweep(Sweep& sweep, OdometryEstimate& est) {
  est.registered = true;
  if (map_.empty()) {
    return;  // the first sweep defines the map
  }
  PosePrior prior;
  prior.T_target_source = T_local_body();
  prior.information = P_.topLeftCorner<6, 6>().inverse();
  std::vector<Eigen::Vector3f> source = registration_points(sweep.points_body);
  RegistrationResult result;
  const bool long_gap = config_.use_imu && sweep.unregistered_s() > config_.long_gap_s;
  const double reach_m = std::max(prediction_reach_m(), long_gap ? config_.long_gap_search_m : 0.0);
  const bool searched = long_gap || reach_m > config_.search_beyond_m;
  // Registration from a start already near the answer (the prediction, or the search's).
  const double radius_m = std::min(reach_m, config_.correspondence_cap_m);
  if (searched) {
    ++counters_.searched_scans;
    std::vector<PosePrior> guesses{prior};
    if (sweep.T_local_body_second_guess) {
      // Beyond the first guess's window the second is searched too (second_guess_window_s).
      const Eigen::Vector2d apart =
          (sweep.T_local_body_second_guess->translation() - prior.T_target_source.translation())
              .head<2>();
      if (apart.lpNorm<Eigen::Infinity>() > std::min(reach_m, config_.search_max_xy_m)) {
        guesses.push_back({*sweep.T_local_body_second_guess, prior.information});
        ++counters_.second_guesses;
      }
    }
    const bool settle = !config_.use_imu && sweep.unregistered_s() > config_.search_settle_after_s;
    SearchOutcome found =
        register_by_search(map_, source, SearchSource::kSweep, guesses, reach_m, settle);
    if (!search_accepts(found, false, local_map_confirmed_inlier_ratio())) {
      // The sweep sees what the local map never did (around a corner, after a long pause):
      // nothing to place it against, so the local map restarts from it at the predicted
      // pose rather than take a pose that fits a few points, or, after a pause without an
      // IMU, at an answer that fits more and that starts agree on (restart_at_answer_starts).
      const bool at_answer = settle && config_.restart_at_answer_starts > 0 &&
                             found.agreeing_starts >= config_.restart_at_answer_starts &&
                             found.inlier_ratio >= config_.search_confirmed_inlier_ratio;
      char reason[220];
      std::snprintf(reason, sizeof(reason),
                    "after %.1f s without a sweep registered only %.0f %% of the sweep fits "
                    "the local map (%d starts agree, %.0f %% elsewhere): the local map "
                    "restarts at the %s",
                    sweep.unregistered_s(), 100.0 * found.inlier_ratio, found.agreeing_starts,
                    100.0 * found.runner_up_ratio,
                    at_answer ? "search's answer" : "predicted pose");
      est.lost_reason = reason;
      Eigen::Isometry3d T_predicted_restarted = Eigen::Isometry3d::Identity();
      if (at_answer) {
        T_predicted_restarted = T_local_body() * found.result.T_target_source.inverse();
        set_T_local_body(found.result.T_target_source);
        // The twist across the pause, as after an accepted search: the one of before it
        // put the next sweep, 0.4 s later, 1.5 m short (VLP-16, it sped up from 3.7 to
        // 7.5 m/s in the pause), where a new map of one sweep held it for good.
        update_twist(sweep);
      }
      restart_keeping_anchor(prior.information, reach_m, T_predicted_restarted);
      return;
    }
    if (!search_accepts(found, false, config_.search_confirmed_inlier_ratio)) {
      ++counters_.young_map_searches_accepted;
    }
    result = std::move(found.result);
    est.inlier_ratio = found.inlier_ratio;
  } else {
    result = register_in_local_map(source, prior.T_target_source, prior, radius_m);
    result = outweigh_imu(sweep, source, prior, reach_m, std::move(result), est);
  }
  if (!config_.use_imu && config_.own_twist_after_gap &&
      sweep.gap_s() > config_.max_rotation_extrapolation_s) {
    result = register_with_own_twist(sweep, source, prior, radius_m, result);
  }
  if (!config_.use_imu) {
    // A searched sweep is deskewed again too: with sweeps dropped, the sweeps after the gaps
    // are searched (a third of the Mid-360's campus A patterns), and deskewed once those
    // runs kept 0.12 % RPE, 0.08 % with.
    if (config_.poor_fit_deskew_passes > 0 &&
        fits_worse_than_usual(result.rms_residual_m, config_.poor_fit_deskew_factor,
                              config_.poor_fit_deskew_floor_m)) {
      result = deskew_poor_fit(sweep, source, prior, radius_m, std::move(result));
    }
    if (!searched && fits_far_worse(result.rms_residual_m)) {
      result = search_poor_fit(source, prior, std::move(result));
    }
  }
  const Eigen::Vector3d p_predicted = x_.p;
  // Biases and gravity are considered (Schmidt) across a long gap and while the IMU is
  // distrusted: neither sweep tells them apart from the gap's or the fault's motion.
  update(result, !long_gap && !imu_distrusted(sweep));
  if (config_.use_imu) {
    twist_ = measured_twist(sweep);
  } else {
    const Vector6d twist_predicted = twist_;
    update_twist(sweep);
    // (Not across a longer pause: the twist is then an average over the pause.)
    if (config_.redeskew_blend > 0.0 && sweep.gap_s() <= config_.max_rotation_extrapolation_s) {
      // The sweep was deskewed with the previous sweep's twist: where the rate changes
      // (a turn's start or end) that lags, and the registered pose sits toward the sweep's
      // middle. It is deskewed again, part of the way to the twist registration just
      // measured: that measurement carries the first pass's lag itself, and all of it made
      // the yaw overshoot and ring after a turn's start (+-1 deg, OS1-64 campus).
      const double b = config_.redeskew_blend;
      Deskewed again = deskew_at_twist(sweep, b * twist_ + (1.0 - b) * twist_predicted);
      sweep.motion = std::move(again.motion);
      sweep.points_body = std::move(again.points_body);
      result = register_in_local_map(registration_points(sweep.points_body), T_local_body(), prior,
                                     config_.registration.max_correspondence_m);
      set_T_local_body(result.T_target_source);
      update_twist(sweep);
    }
  }
  est.fitness_m = result.rms_residual_m;
  est.correspondences = result.correspondences;
  est.degenerate = result.degenerate;
  est.translation_eigen_ratio = result.translation_eigen_ratio;
  est.rotation_eigen_ratio = result.rotation_eigen_ratio;
  counters_.degenerate_scans += result.degenerate ? 1 : 0;
  // Without an IMU nothing holds a degenerate direction but the constant-velocity guess;
  // past lost_after_degenerate_s of it the estimate along that direction is not trusted.
  degenerate_since_us_ = result.degenerate ? std::min(degenerate_since_us_, sweep.end_utime)
                                           : std::numeric_limits<int64_t>::max();
  const double degenerate_s = (sweep.end_utime - degenerate_since_us_) * 1e-6;
  if (!config_.use_imu && degenerate_s >= config_.lost_after_degenerate_s) {
    char reason[160];
    std::snprintf(reason, sizeof(reason),
                  "degenerate for %.1f s without an IMU: the motion along the weak direction is "
                  "the constant-velocity guess",
                  degenerate_s);
    est.lost_reason = reason;
  }
  // A standing vehicle's sweeps, all from one viewpoint, match little and need not.
  if (!est.standing) {
    recent_fits_.push_back({sweep.end_utime, result.correspondences, est.inlier_ratio});
  }
  if (config_.use_imu) {
    recent_imu_verdicts_.emplace_back(sweep.end_utime, !est.imu_disagreement.empty());
  }
  if (const std::optional<HealthProblem> problem = health_problem(sweep, p_predicted)) {
    est.lost_reason = problem->reason + (problem->local_map_suspect
                                             ? ": the local map restarts at the last trusted pose"
                                             : ": back to the last trusted pose and velocity");
    ++counters_.health_resets;
    reset_to(sweep, problem->local_map_suspect);
    // The velocity is now the last trusted one, not this sweep's: the next sweeps correct it.
    imu_distrusted_until_us_ = sweep.end_utime + to_us(config_.imu_distrust_hold_s);
  } else {
    if (!imu_distrusted(sweep)) {
      trusted_velocity_ = x_.v;
    }
    report_lasting_imu_fault(sweep, est);
  }
}

void LidarInertialOdometry::report_lasting_imu_fault(const Sweep& sweep, OdometryEstimate& est) {
  const std::optional<double> overruled = imu_overruled_fraction(sweep.end_utime);
  if (!overruled || *overruled < config_.imu_fault_fraction) {
    return;
  }
  // Said, not reset: the LiDAR's own motion is what carries the estimate now, and the last
  // trusted velocity is from before the fault (a reset to it every 5 s took a gyro step of
  // 0.3 rad/s from 1.3 to 215 m).
  char text[240];
  std::snprintf(text, sizeof(text),
                "for %.1f s the LiDAR overruled the IMU on %.0f %% of the sweeps (at least "
                "imu_fault_fraction %.0f %%): a lasting IMU fault; following the LiDAR's own "
                "motion",
                config_.imu_fault_window_s, 100.0 * *overruled, 100.0 * config_.imu_fault_fraction);
  est.lost_reason = text;
  recent_imu_verdicts_.clear();  // said again after another full window, not every sweep
  if (config_.imu_fault_gyro_bias_sigma_rps > 0.0) {
    // Learned by the next sweeps' updates (the rotation's innovation over the sweep, Eq. 5):
    // their prediction's rotation widens with the bias's sigma, so the IMU passes the
    // consistency test again and the update reaches the biases.
    P_.middleRows<3>(kBg).setZero();
    P_.middleCols<3>(kBg).setZero();
    P_.block<3, 3>(kBg, kBg) =
        Eigen::Matrix3d::Identity() * std::pow(config_.imu_fault_gyro_bias_sigma_rps, 2);
    imu_distrusted_until_us_ = sweep.end_utime;
    est.lost_reason += "; the gyro bias is learned again";
  }
}

RegistrationResult LidarInertialOdometry::register_in_local_map(
    const std::vector<Eigen::Vector3f>& source, const Eigen::Isometry3d& T_local_body_guess,
    const PosePrior& prior, double radius_m) const {
  // Point-to-plane registration (Eq. 6) against the local map, the prediction as prior.
  return register_point_to_plane(source, map_, T_local_body_guess, prior,
                                 registration_config(radius_m), T_body_lidar_.translation());
}

std::optional<double> LidarInertialOdometry::usual_fit_m() const {
  if (static_cast<int>(recent_fitness_m_.size()) < config_.poor_fit_window / 2) {
    return std::nullopt;
  }
  std::vector<double> fits_m(recent_fitness_m_.begin(), recent_fitness_m_.end());
  return median(fits_m);
}

bool LidarInertialOdometry::fits_worse_than_usual(double rms_residual_m, double factor,
                                                  double floor_m) const {
  const std::optional<double> usual_m = usual_fit_m();
  return usual_m && rms_residual_m > std::max(floor_m, factor * *usual_m);
}

bool LidarInertialOdometry::fits_far_worse(double rms_residual_m) {
  const bool far_worse =
      config_.poor_fit_factor > 0.0 &&
      fits_worse_than_usual(rms_residual_m, config_.poor_fit_factor, config_.poor_fit_floor_m);
  if (!far_worse) {
    recent_fitness_m_.push_back(rms_residual_m);
    while (static_cast<int>(recent_fitness_m_.size()) > config_.poor_fit_window) {
      recent_fitness_m_.pop_front();
    }
  }
  return far_worse;
}

RegistrationResult LidarInertialOdometry::deskew_poor_fit(Sweep& sweep,
                                                          std::vector<Eigen::Vector3f>& source,
                                                          const PosePrior& prior, double radius_m,
                                                          RegistrationResult result) {
  // The sweep was deskewed with the previous sweep's twist; where the rate changed within
  // it (a turn's end or start) its points are warped, and the best rigid fit of a warped
  // sweep lies between the prediction and the truth. Deskewed again along the motion from
  // the previous sweep's end to the pose just registered, each pass takes part of the way
  // to the motion the sweep saw. The pass that fits best is kept: where the previous
  // sweep's pose is itself off, the passes walk on past the best. And only where it fits
  // clearly better: on open ground a pass along a twist of noise fits a little better too.
  if (sweep.gap_s() > config_.max_rotation_extrapolation_s) {
    return result;
  }
  const double first_rms_m = result.rms_residual_m;
  // A tighter fit of fewer points is no better.
  const double first_inliers = inlier_ratio(result.T_target_source, source);
  Eigen::Isometry3d T_local_body = result.T_target_source;
  for (int pass = 0; pass < config_.poor_fit_deskew_passes; ++pass) {
    Deskewed deskewed = deskew_at_twist(sweep, twist_to(sweep, T_local_body));
    std::vector<Eigen::Vector3f> pass_source = registration_points(deskewed.points_body);
    RegistrationResult again = register_in_local_map(pass_source, T_local_body, prior, radius_m);
    T_local_body = again.T_target_source;
    if (again.rms_residual_m < result.rms_residual_m &&
        again.rms_residual_m <= (1.0 - config_.poor_fit_deskew_min_gain) * first_rms_m &&
        inlier_ratio(again.T_target_source, pass_source) >= first_inliers) {
      sweep.motion = std::move(deskewed.motion);
      sweep.points_body = std::move(deskewed.points_body);
      source = std::move(pass_source);
      result = std::move(again);
    }
  }
  counters_.poor_fits_deskewed += result.rms_residual_m < first_rms_m ? 1 : 0;
  return result;
}

RegistrationResult LidarInertialOdometry::register_with_own_twist(
    Sweep& sweep, std::vector<Eigen::Vector3f>& source, const PosePrior& prior, double radius_m,
    const RegistrationResult& result) {
  const double duration_s = (sweep.end_utime - sweep.start_utime) * 1e-6;
  if (!(duration_s > 0.0)) {
    return result;  // no spread in time: nothing tells the twist
  }
  // Each registration point's time before the sweep's end, chosen as registration_points()
  // chooses its point.
  std::vector<double> tau_s;
  tau_s.reserve(sweep.sparse.size());
  for (const LidarPoint& p : sweep.sparse) {
    tau_s.push_back(static_cast<float>(p.time_offset_s - duration_s));
  }
  tau_s = evenly_spaced(tau_s, static_cast<size_t>(config_.max_registration_points));
  // The twist the sweep was deskewed with, in its end's body frame.
  const Eigen::Isometry3d T_end_start =
      sweep.motion.pose_at(sweep.end_utime).inverse() * sweep.motion.pose_at(sweep.start_utime);
  Vector6d deskewed_with;
  deskewed_with.head<3>() = -T_end_start.translation() / duration_s;
  deskewed_with.tail<3>() = -so3::log(T_end_start.linear()) / duration_s;
  // Prior sigmas of the correction (dv, dw) in the body frame: z is up, x and y of dw are the
  // roll and pitch rates.
  Vector6d sigma;
  sigma << config_.motion_translation_sigma_mps, config_.motion_translation_sigma_mps,
      config_.own_twist_vertical_sigma_mps, config_.own_twist_tilt_rate_sigma_rps,
      config_.own_twist_tilt_rate_sigma_rps, config_.motion_rotation_sigma_rps;
  const Matrix6d twist_information = sigma.array().square().inverse().matrix().asDiagonal();
  const TwistRegistrationResult joint = register_point_to_plane_with_twist(
      source, tau_s, map_, result.T_target_source, prior, twist_information,
      registration_config(radius_m), T_body_lidar_.translation());
  // The correction is first order in the sweep's time; deskewed along the corrected twist and
  // registered again, the points the local map takes are deskewed exactly.
  const Vector6d own = deskewed_with + joint.twist_correction;
  // The sweep's twist in its start's body frame, as constant_twist_motion reads it: the
  // end frame's velocity turned back by the sweep's rotation (0.05 rad in a turn at 0.5
  // rad/s, a lateral 0.35 m/s at 7 m/s). The end frame's is the next prediction's twist.
  Vector6d own_at_start = own;
  own_at_start.head<3>() = so3::exp(own.tail<3>() * duration_s) * own.head<3>();
  sweep.motion = constant_twist_motion(joint.pose.T_target_source, sweep.start_utime,
                                       sweep.end_utime, own_at_start);
  sweep.points_body =
      deskew(sweep.sparse, sweep.start_utime, sweep.end_utime, sweep.motion, T_body_lidar_);
  sweep.own_twist = own;
  source = registration_points(sweep.points_body);
  ++counters_.own_twists_after_gaps;
  return register_in_local_map(source, joint.pose.T_target_source, prior, radius_m);
}

RegistrationResult LidarInertialOdometry::search_poor_fit(
    const std::vector<Eigen::Vector3f>& source, const PosePrior& prior, RegistrationResult result) {
  ++counters_.poor_fits_searched;
  // The prediction widened to the swerve it may have missed.
  Matrix6d covariance = prior.information.inverse();
  const double k = config_.correspondence_sigmas;
  covariance.diagonal().segment<3>(kPos).array() += std::pow(config_.poor_fit_search_m / k, 2);
  covariance.diagonal().segment<3>(kRot).array() +=
      std::pow(config_.poor_fit_search_yaw_rad / k, 2);
  const PosePrior wide{prior.T_target_source, covariance.inverse()};
  SearchOutcome found = register_by_search(map_, source, SearchSource::kSweep, {wide},
                                           config_.poor_fit_search_m, true);
  const double before = inlier_ratio(result.T_target_source, source);
  if (!search_accepts(found, false, config_.search_confirmed_inlier_ratio) ||
      found.inlier_ratio <= before) {
    return result;
  }
  ++counters_.poor_fits_moved;
  return std::move(found.result);
}

bool LidarInertialOdometry::imu_distrusted(const Sweep& sweep) const {
  return config_.use_imu && sweep.end_utime <= imu_distrusted_until_us_;
}

double LidarInertialOdometry::innovation_nis(const RegistrationResult& result) const {
  // The registration solved prior + LiDAR: d = K nu with K = P (P + R)^-1, R the inverse of
  // the LiDAR's information H. So y = P^-1 d = (P + R)^-1 nu, and
  // nu' (P + R)^-1 nu = y' (P + R) y = y' P y + y' H^-1 y. (H regularized: along a
  // degenerate direction the registration leaves the prior, and y there is 0.)
  const Matrix6d P_pp = P_.topLeftCorner<6, 6>();
  const Vector6d y = P_pp.ldlt().solve(se3::minus(result.T_target_source, T_local_body()));
  Matrix6d H = result.information;
  H.diagonal().array() += 1e-6;
  return y.dot(P_pp * y) + y.dot(H.ldlt().solve(y));
}

RegistrationResult LidarInertialOdometry::outweigh_imu(Sweep& sweep,
                                                       const std::vector<Eigen::Vector3f>& source,
                                                       PosePrior prior, double reach_m,
                                                       RegistrationResult result,
                                                       OdometryEstimate& est) {
  if (!config_.use_imu) {
    return result;
  }
  // A prediction off by degrees leaves registration stuck near where it started, with a
  // small innovation (gyro +1 rad/s, HDL-32E: NIS 7; +5 rad/s: 13) but a fraction of the
  // usual points on the map (0.32 against 0.73). (Also without the test below: the health
  // check weak_fit_inlier_ratio reads it.)
  est.inlier_ratio = inlier_ratio(result.T_target_source, source);
  if (config_.imu_consistency_nis == 0.0) {
    return result;
  }
  const double nis = innovation_nis(result);
  const bool contradicted = nis > config_.imu_consistency_nis;
  if (contradicted) {
    imu_distrusted_until_us_ = sweep.end_utime + to_us(config_.imu_distrust_hold_s);
  }
  const bool collapsed = fit_collapsed(sweep.end_utime, est.inlier_ratio);
  if (!imu_distrusted(sweep) && !collapsed) {
    return result;
  }
  // The hold matters: within a fault some sweeps pass the test by chance (the registration
  // is pulled towards the prediction it contradicts), and those left their velocity
  // uncorrected (100 m/s^2 for 0.25 s: a reset instead of 0.04 m ATE).
  const double dt_s = std::max(sweep.gap_s(), 1e-3);
  const StateMatrix P_predicted = P_;
  double accel = 0.0;
  double gyro = 0.0;
  // (A collapsed fit alone widens nothing: it only asks the LiDAR's own motion, below.)
  for (int k = 0; imu_distrusted(sweep) && k <= config_.imu_distrust_doublings; ++k) {
    accel = std::ldexp(config_.imu_distrust_accel_mps2, k);
    gyro = std::ldexp(config_.imu_distrust_gyro_rps, k);
    P_ = P_predicted;
    widen_prediction(accel, gyro, dt_s);
    prior.information = P_.topLeftCorner<6, 6>().inverse();
    RegistrationResult widened = register_in_local_map(
        source, prior.T_target_source, prior,
        std::min(std::max(prediction_reach_m(), reach_m), config_.correspondence_cap_m));
    // Widened until the LiDAR, not the prior, places the sweep: the pose stops moving.
    const Vector6d moved = se3::minus(widened.T_target_source, result.T_target_source);
    result = std::move(widened);
    if (moved.head<3>().norm() < config_.imu_distrust_settled_m &&
        moved.tail<3>().norm() < config_.imu_distrust_settled_rad) {
      break;
    }
  }
  est.inlier_ratio = inlier_ratio(result.T_target_source, source);
  // (Taken only where it fits as a sweep must: garbage from the LiDAR fits no motion.)
  if (OwnMotion own = register_own_motion(sweep, reach_m);
      own.inlier_ratio > config_.own_motion_inlier_gain * est.inlier_ratio &&
      own.inlier_ratio >= config_.search_min_inlier_ratio) {
    // The filter's rotation and velocity must be free to follow: the update takes the pose
    // as registered, the velocity through the widened correlations.
    const double off_rad =
        se3::rotation_angle(T_local_body().inverse() * own.result.T_target_source);
    accel = std::max(accel, config_.imu_distrust_accel_mps2);
    gyro = std::max(gyro, off_rad / dt_s);
    P_ = P_predicted;
    widen_prediction(accel, gyro, dt_s);
    imu_distrusted_until_us_ = sweep.end_utime + to_us(config_.imu_distrust_hold_s);
    ++counters_.imu_disagreements;
    char text[240];
    std::snprintf(text, sizeof(text),
                  "the sweep fits the LiDAR's own motion better than the IMU's (%.0f %% against "
                  "%.0f %% of its points within %.2f m of the map): the IMU's rotation over "
                  "the sweep is off by %.1f deg (a gyro fault?); following the LiDAR",
                  100.0 * own.inlier_ratio, 100.0 * est.inlier_ratio, config_.search_inlier_m,
                  off_rad * so3::kRadToDeg);
    est.imu_disagreement = text;
    est.inlier_ratio = own.inlier_ratio;
    sweep.motion = std::move(own.motion);
    sweep.points_body = std::move(own.points_body);
    return std::move(own.result);
  }
  if (contradicted) {
    ++counters_.imu_disagreements;
    char text[240];
    std::snprintf(
        text, sizeof(text),
        "the LiDAR contradicts the IMU's prediction (NIS %.0f, beyond "
        "imu_consistency_nis %.1f; registration moved it %.2f m, %.2f deg): the "
        "prediction is widened to %.0f m/s^2, %.1f rad/s (an IMU bias step or fault?)",
        nis, config_.imu_consistency_nis,
        (result.T_target_source.translation() - T_local_body().translation()).norm(),
        se3::rotation_angle(T_local_body().inverse() * result.T_target_source) * so3::kRadToDeg,
        accel, gyro);
    est.imu_disagreement = text;
  }
  return result;
}

LidarInertialOdometry::OwnMotion LidarInertialOdometry::register_own_motion(const Sweep& sweep,
                                                                            double reach_m) const {
  OwnMotion own;
  own.motion =
      constant_twist_motion(sweep.T_local_body_before, sweep.utime_before, sweep.end_utime, twist_);
  own.points_body =
      deskew(sweep.sparse, sweep.start_utime, sweep.end_utime, own.motion, T_body_lidar_);
  const std::vector<Eigen::Vector3f> source = registration_points(own.points_body);
  // The prior of a LiDAR-only prediction over the interval, around the twist's pose.
  const double dt_s = std::max(sweep.gap_s(), 1e-3);
  Matrix6d covariance = P_.topLeftCorner<6, 6>();
  covariance.diagonal() += constant_velocity_variance(dt_s);
  const MotionSample& end = own.motion.samples().back();
  const PosePrior prior{se3::make(end.R, end.p), covariance.inverse()};
  own.result = register_in_local_map(
      source, prior.T_target_source, prior,
      std::min(std::max(reach_of(covariance), reach_m), config_.correspondence_cap_m));
  own.inlier_ratio = inlier_ratio(own.result.T_target_source, source);
  return own;
}

bool LidarInertialOdometry::fit_collapsed(int64_t now_us, double inlier_ratio) const {
  std::vector<double> ratios;
  for (const RecentFit& fit : recent_fits_) {
    if (now_us - fit.utime_us <= to_us(config_.weak_fit_window_s)) {
      ratios.push_back(fit.inlier_ratio);
    }
  }
  return ratios.size() >= kMinWindowSweeps &&
         inlier_ratio < config_.fit_collapse_fraction * median(ratios);
}

double LidarInertialOdometry::inlier_ratio(const Eigen::Isometry3d& T_local_body,
                                           const std::vector<Eigen::Vector3f>& source) const {
  return source.empty() ? 0.0
                        : inliers(map_, T_local_body, source) / static_cast<double>(source.size());
}

int LidarInertialOdometry::inliers(const VoxelHashMap& target,
                                   const Eigen::Isometry3d& T_target_body,
                                   const std::vector<Eigen::Vector3f>& source) const {
  const Eigen::Isometry3f T = T_target_body.cast<float>();
  const auto radius = static_cast<float>(config_.search_inlier_m);
  int count = 0;
  for (const Eigen::Vector3f& p : source) {
    count += target.nearest<1>(T * p, radius).count > 0;
  }
  return count;
}

void LidarInertialOdometry::widen_prediction(double accel_mps2, double gyro_rps, double dt_s) {
  // The velocity at the interval's start uncertain by accel * dt, and the acceleration over
  // it by accel: position and velocity then correlate between a pure velocity error (the
  // LiDAR's position innovation / dt corrects the velocity) and a pure acceleration
  // (2 / dt), so the correction neither lags a lasting fault nor rings after it. With
  // the acceleration alone the velocity alternated by +-0.5 m/s from sweep to sweep.
  const double q = accel_mps2 * accel_mps2;
  const double dt2 = dt_s * dt_s;
  const Eigen::Matrix3d R_body_local = x_.R.transpose();  // position errors are body-frame
  P_.block<3, 3>(kPos, kPos).diagonal().array() += q * dt2 * dt2 * (0.25 + 1.0);
  P_.block<3, 3>(kPos, kVel) += R_body_local * (q * dt2 * dt_s * (0.5 + 1.0));
  P_.block<3, 3>(kVel, kPos) += R_body_local.transpose() * (q * dt2 * dt_s * (0.5 + 1.0));
  P_.block<3, 3>(kVel, kVel).diagonal().array() += q * dt2 * (1.0 + 1.0);
  P_.block<3, 3>(kRot, kRot).diagonal().array() += gyro_rps * gyro_rps * dt2;
}

std::optional<LidarInertialOdometry::HealthProblem> LidarInertialOdometry::health_problem(
    const Sweep& sweep, const Eigen::Vector3d& p_predicted) {
  char text[200];
  bool local_map_suspect = !config_.use_imu;
  const double dt = std::max(sweep.gap_s(), 1e-3);
  const double speed = x_.v.norm();
  const double accel = (x_.v - sweep.velocity_before).norm() / dt;
  const double jump = (x_.p - p_predicted).norm();
  if (speed > config_.max_speed_mps) {
    std::snprintf(text, sizeof(text), "speed %.1f m/s beyond max_speed_mps %.1f", speed,
                  config_.max_speed_mps);
  } else if (config_.use_imu && accel > config_.max_accel_mps2 && !imu_distrusted(sweep)) {
    // (Without an IMU the velocity is a difference of poses 0.1 s apart, too noisy for this.)
    std::snprintf(text, sizeof(text),
                  "the velocity changed by %.1f m/s in %.2f s (%.0f m/s^2, beyond "
                  "max_accel_mps2 %.0f)",
                  accel * dt, dt, accel, config_.max_accel_mps2);
  } else if (config_.use_imu && jump > config_.max_jump_m) {
    // Without an IMU the search after a pause may move the pose far: that is its purpose.
    std::snprintf(text, sizeof(text),
                  "the registration moved the pose %.1f m from the IMU's prediction (beyond "
                  "max_jump_m %.1f)",
                  jump, config_.max_jump_m);
  } else if (const std::optional<WindowFit> fit = window_fit(sweep.end_utime);
             fit && fit->correspondences < config_.weak_fit_correspondences) {
    std::snprintf(text, sizeof(text),
                  "for %.1f s the sweeps matched a median of %d planes of the local map "
                  "(fewer than weak_fit_correspondences %d): it no longer fits what the "
                  "LiDAR sees",
                  config_.weak_fit_window_s, fit->correspondences,
                  config_.weak_fit_correspondences);
    local_map_suspect = true;
  } else if (fit && config_.use_imu && fit->inlier_ratio < config_.weak_fit_inlier_ratio) {
    std::snprintf(text, sizeof(text),
                  "for %.1f s the sweeps put a median of %.0f %% of their points within "
                  "%.2f m of the local map (below weak_fit_inlier_ratio %.0f %%): neither "
                  "the IMU's motion nor the LiDAR's own fits them (an IMU fault?)",
                  config_.weak_fit_window_s, 100.0 * fit->inlier_ratio, config_.search_inlier_m,
                  100.0 * config_.weak_fit_inlier_ratio);
    local_map_suspect = true;
  } else {
    return std::nullopt;
  }
  return HealthProblem{text, local_map_suspect};
}

std::optional<LidarInertialOdometry::WindowFit> LidarInertialOdometry::window_fit(int64_t now_us) {
  const auto window_us = static_cast<int64_t>(config_.weak_fit_window_s * 1e6);
  // The window must lie on the current local map: a new one matches little at first.
  const bool full = !recent_fits_.empty() && now_us - recent_fits_.front().utime_us >= window_us;
  while (!recent_fits_.empty() && now_us - recent_fits_.front().utime_us > window_us) {
    recent_fits_.pop_front();
  }
  // And hold enough sweeps for a median: after a pause of seconds it may hold one.
  if (!full || recent_fits_.size() < kMinWindowSweeps) {
    return std::nullopt;
  }
  std::vector<int> counts;
  std::vector<double> ratios;
  for (const RecentFit& fit : recent_fits_) {
    counts.push_back(fit.correspondences);
    ratios.push_back(fit.inlier_ratio);
  }
  return WindowFit{median(counts), median(ratios)};
}

std::optional<double> LidarInertialOdometry::imu_overruled_fraction(int64_t now_us) {
  const int64_t window_us = to_us(config_.imu_fault_window_s);
  const bool full =
      !recent_imu_verdicts_.empty() && now_us - recent_imu_verdicts_.front().first >= window_us;
  while (!recent_imu_verdicts_.empty() && now_us - recent_imu_verdicts_.front().first > window_us) {
    recent_imu_verdicts_.pop_front();
  }
  if (window_us == 0 || !full || recent_imu_verdicts_.size() < kMinWindowSweeps) {
    return std::nullopt;
  }
  const auto overruled = std::count_if(recent_imu_verdicts_.begin(), recent_imu_verdicts_.end(),
                                       [](const auto& verdict) { return verdict.second; });
  return static_cast<double>(overruled) / static_cast<double>(recent_imu_verdicts_.size());
}

void LidarInertialOdometry::reset_to(const Sweep& sweep, bool restart_map) {
  // Back to the previous sweep's pose and the last trusted velocity, with the uncertainty
  // of a restart: the pose, rotation and velocity forget their correlations; biases and
  // gravity keep theirs. (The previous sweep's velocity may be the fault's: resetting to
  // it repeated the runaway, reset after reset; docs/odometry.md.)
  set_T_local_body(sweep.T_local_body_before);
  x_.v = config_.use_imu ? trusted_velocity_ : sweep.velocity_before;
  twist_.setZero();
  twist_.head<3>() = x_.R.transpose() * x_.v;
  StateVector sigma = P_.diagonal().cwiseSqrt();
  sigma.segment<3>(kRot).setConstant(0.05);
  sigma.segment<3>(kPos).setConstant(1.0);
  sigma.segment<3>(kVel).setConstant(2.0);
  const StateMatrix kept = P_;
  P_ = sigma.cwiseAbs2().asDiagonal();
  P_.bottomRightCorner<kStateDim - kBg, kStateDim - kBg>() =
      kept.bottomRightCorner<kStateDim - kBg, kStateDim - kBg>();
  recent_imu_verdicts_.clear();
  if (restart_map) {
    restart_local_map();
  }
}

void LidarInertialOdometry::restart_keeping_anchor(const Matrix6d& information, double reach_m,
                                                   const Eigen::Isometry3d& T_predicted_restarted) {
  if (config_.reanchor_attempts == 0) {
    restart_local_map();
  } else if (anchor_) {
    // Restarted again before the first was found (the restarted map's first sweep fit
    // nothing either): the anchor stays the map of before the first; the error since is
    // within the larger reach.
    anchor_->reach_m = std::max(anchor_->reach_m, reach_m);
    anchor_->T_predicted_restarted = anchor_->T_predicted_restarted * T_predicted_restarted;
    restart_local_map();
  } else {
    Anchor anchor{std::move(map_), information, reach_m, state_utime_, state_utime_};
    anchor.map_inserts = map_inserts_;
    anchor.T_predicted_restarted = T_predicted_restarted;
    restart_local_map();
    anchor_ = std::move(anchor);
  }
  // The sweep that could not be placed begins the new local map at the restart's pose, so
  // in that map the pose is exact; the restart's spread stays with the anchor. Kept in P_,
  // it had the next sweep searched too, against a map of one sweep, which the next sweep
  // of a sparse LiDAR fits by 13-15 %: the local map restarted again and again (Mid-360
  // without an IMU, in an experiment: at 181.4, 181.5 and 183.7 s, 7.6 m off).
  P_.topRows<6>().setZero();
  P_.leftCols<6>().setZero();
  P_.block<3, 3>(kRot, kRot).diagonal().setConstant(std::pow(kOriginRotationSigmaRad, 2));
  P_.block<3, 3>(kPos, kPos).diagonal().setConstant(std::pow(kOriginPositionSigmaM, 2));
}

void LidarInertialOdometry::reanchor(OdometryEstimate& est) {
  if (!anchor_ || !est.lost_reason.empty() ||
      state_utime_ - anchor_->new_map_utime <
          to_us(config_.reanchor_after_s * (anchor_->attempts + 1))) {
    return;
  }
  ++anchor_->attempts;
  // The whole new local map, in the body frame, is the "sweep" searched for.
  const std::vector<Eigen::Vector3f> new_map_points = map_.points();
  const Eigen::Isometry3f T_body_local = T_local_body().inverse().cast<float>();
  std::vector<Eigen::Vector3f> source = registration_points(new_map_points);
  for (Eigen::Vector3f& p : source) {
    p = T_body_local * p;
  }
  // The new map holds its drift since the restart, small beside the restart's error: the
  // restart's uncertainty, around the current pose as it would be had the local map
  // restarted at the prediction.
  const PosePrior prior{anchor_->T_predicted_restarted * T_local_body(), anchor_->information};
  const SearchOutcome found = register_by_search(anchor_->map, source, SearchSource::kLocalMap,
                                                 {prior}, anchor_->reach_m, true);
  if (!search_accepts(found, true, config_.search_confirmed_inlier_ratio)) {
    if (anchor_->attempts >= config_.reanchor_attempts) {
      anchor_.reset();  // the new local map is the only one from now on
    }
    return;
  }
  const Eigen::Isometry3d T_old_new = found.result.T_target_source * T_local_body().inverse();
  const Eigen::Isometry3d jump = T_local_body().inverse() * found.result.T_target_source;
  VoxelHashMap merged = std::move(anchor_->map);
  merged.insert(map_, T_old_new.cast<float>());
  move_local_frame(T_old_new, anchor_->first_restart_utime);
  map_ = std::move(merged);
  map_inserts_ += anchor_->map_inserts;
  char text[200];
  std::snprintf(text, sizeof(text),
                "the local map of %.1f s since a restart found in the one before it (%.0f %% "
                "of its points fit): the pose moved %.2f m and %.1f deg onto it",
                (state_utime_ - anchor_->new_map_utime) * 1e-6, 100.0 * found.inlier_ratio,
                jump.translation().norm(), se3::rotation_angle(jump) * so3::kRadToDeg);
  est.reanchored = text;
  ++counters_.reanchors;
  anchor_.reset();
}

void LidarInertialOdometry::move_local_frame(const Eigen::Isometry3d& T_old_new,
                                             int64_t since_utime) {
  const Eigen::Matrix3d& R = T_old_new.linear();
  const Eigen::Vector3d g_new = x_.g;
  x_.R = R * x_.R;
  x_.p = T_old_new * x_.p;
  x_.v = R * x_.v;
  x_.g = R * x_.g;
  trusted_velocity_ = R * trusted_velocity_;
  // Pose errors are in the body frame and stay; velocity and gravity errors turn with the
  // frame (gravity's from the tangent plane at g_new to that at R g_new).
  StateMatrix J = StateMatrix::Identity();
  J.block<3, 3>(kVel, kVel) = R;
  J.block<2, 2>(kGrav, kGrav) =
      gravity_tangent_basis(x_.g).transpose() * R * gravity_tangent_basis(g_new);
  P_ = J * P_ * J.transpose();
  last_insert_T_local_body_ = T_old_new * last_insert_T_local_body_;
  last_keyframe_T_local_body_ = T_old_new * last_keyframe_T_local_body_;
  for (HistoryEntry& h : history_) {
    if (h.utime_us >= since_utime) {
      h.T_local_body = T_old_new * h.T_local_body;
    }
  }
}

void LidarInertialOdometry::restart_local_map() {
  ++counters_.map_restarts;
  if (anchor_) {
    anchor_->new_map_utime = state_utime_;
  }
  map_ = VoxelHashMap(config_.map);
  map_inserts_ = 0;
  recent_fits_.clear();
  recent_fitness_m_.clear();
}

LidarInertialOdometry::SearchOutcome LidarInertialOdometry::register_by_search(
    const VoxelHashMap& target, const std::vector<Eigen::Vector3f>& source,
    SearchSource source_kind, const std::vector<PosePrior>& guesses, double reach_m,
    bool settle) const {
  const double half_xy_m = std::min(reach_m, config_.search_max_xy_m);
  // Wider windows in coarser cells: at most 21 x 21 shifts per yaw.
  CorrelativeSearchConfig search = config_.search;
  search.cell_m = std::max(search.cell_m, half_xy_m / 10.0);
  // Scored by the points that land within search_inlier_m of a map point (inliers): along a
  // street, a start shifted by a metre finds as many planes (its walls) but not its poles
  // and corners.
  //
  // The search is level (x, y, yaw at the predicted height): over a pause of seconds on
  // rolling ground the predicted height is off by metres (the pre-pause velocity carried up
  // or down a slope), beyond what registration's radius reaches, and a sweep registered a
  // few metres high tilted to meet the ground (OS1-64, LiDAR-only, 5 s gaps: 3 m and 2.6
  // degrees). Each start's height is searched first, in steps of search_inlier_m.
  const std::vector<Eigen::Vector3f> probe =
      evenly_spaced(source, static_cast<size_t>(config_.search.max_points));
  const double max_dz = std::min(reach_m, config_.search_max_z_m);
  const auto at_best_height = [&](Eigen::Isometry3d T) {
    const Eigen::Vector3d start = T.translation();
    int best = -1;
    double best_dz = 0.0;
    for (double dz = -max_dz; dz <= max_dz + 1e-9; dz += config_.search_inlier_m) {
      T.translation() = start + Eigen::Vector3d(0.0, 0.0, dz);
      const int n = inliers(target, T, probe);
      if (n > best || (n == best && std::abs(dz) < std::abs(best_dz))) {
        best = n;
        best_dz = dz;
      }
    }
    T.translation() = start + Eigen::Vector3d(0.0, 0.0, best_dz);
    return T;
  };
  // Each start is within a search cell of its answer, so registration (point-to-plane,
  // Eq. 6) refines it as a well predicted sweep; its guess's wide prior still holds what the
  // scan leaves weak (a street's length).
  RegistrationConfig refine = registration_config(search.cell_m);
  refine.reject_back_faces &= source_kind == SearchSource::kSweep;
  const CorrelativeSearch correlative(target.points(), search);
  struct Answer {
    RegistrationResult result;
    SearchCandidate score;
    const PosePrior* guess;
  };
  std::vector<Answer> answers;
  for (const PosePrior& guess : guesses) {
    const Eigen::Isometry3d& T_guess = guess.T_target_source;
    const double yaw = so3::yaw(T_guess.linear());
    const Matrix6d covariance = guess.information.inverse();
    const double sigma_r = std::sqrt(covariance.block<3, 3>(3, 3).diagonal().maxCoeff());
    SearchWindow window;
    window.x_m = T_guess.translation().x();
    window.y_m = T_guess.translation().y();
    window.z_m = T_guess.translation().z();
    window.yaw_rad = yaw;
    window.half_xy_m = half_xy_m;
    window.half_yaw_rad =
        std::min(config_.correspondence_sigmas * sigma_r, config_.search_max_yaw_rad);
    const Eigen::Matrix3d R_level_body = so3::exp(Eigen::Vector3d(0, 0, -yaw)) * T_guess.linear();
    std::vector<Eigen::Isometry3d> starts{at_best_height(T_guess)};
    for (const ScoredPose& peak : correlative.search(source, R_level_body, window)) {
      starts.push_back(at_best_height(peak.T_map_body));
    }
    for (const Eigen::Isometry3d& start : starts) {
      RegistrationResult r = register_point_to_plane(source, target, start, guess, refine,
                                                     T_body_lidar_.translation());
      const int n = inliers(target, r.T_target_source, source);
      const Vector6d delta = se3::minus(r.T_target_source, guess.T_target_source);
      answers.push_back(
          {std::move(r), {n, std::exp(-0.5 * delta.dot(guess.information * delta))}, &guess});
    }
  }
  std::vector<SearchCandidate> scores;
  for (const Answer& answer : answers) {
    scores.push_back(answer.score);
  }
  const Answer& best =
      answers[pick_search_answer(scores, config_.search_tie_fraction, config_.search_tie_odds)];
  SearchOutcome out;
  out.result = best.result;
  int best_inliers = best.score.inliers;
  if (settle) {
    RegistrationConfig normal_kernel = refine;
    normal_kernel.cauchy_scale_m = config_.registration.cauchy_scale_m;
    RegistrationResult settled =
        register_point_to_plane(source, target, best.result.T_target_source, *best.guess,
                                normal_kernel, T_body_lidar_.translation());
    const int settled_inliers = inliers(target, settled.T_target_source, source);
    if (settled_inliers >= best_inliers) {
      out.result = std::move(settled);
      best_inliers = settled_inliers;
    }
  }
  const double points = static_cast<double>(source.size());
  out.inlier_ratio = best_inliers / points;
  for (const Answer& answer : answers) {
    const double ratio = answer.score.inliers / points;
    const Eigen::Isometry3d d =
        best.result.T_target_source.inverse() * answer.result.T_target_source;
    if (d.translation().norm() <= config_.search_agree_m &&
        se3::rotation_angle(d) <= config_.search_agree_rad) {
      ++out.agreeing_starts;
    } else {
      out.runner_up_ratio = std::max(out.runner_up_ratio, ratio);
      out.weighted_runner_up =
          std::max(out.weighted_runner_up,
                   ratio * std::min(1.0, answer.score.prior_density / best.score.prior_density));
    }
  }
  return out;
}

bool LidarInertialOdometry::search_accepts(const SearchOutcome& found, bool weigh_by_prior,
                                           double confirmed_inlier_ratio) const {
  const double rival = weigh_by_prior ? found.weighted_runner_up : found.runner_up_ratio;
  return found.inlier_ratio >= config_.search_min_inlier_ratio ||
         (found.inlier_ratio >= confirmed_inlier_ratio &&
          found.agreeing_starts >= config_.search_confirming_starts &&
          rival < config_.search_runner_up_fraction * found.inlier_ratio);
}

double LidarInertialOdometry::local_map_confirmed_inlier_ratio() const {
  return map_inserts_ < config_.young_map_inserts
             ? std::min(config_.young_map_confirmed_inlier_ratio,
                        config_.search_confirmed_inlier_ratio)
             : config_.search_confirmed_inlier_ratio;
}

void LidarInertialOdometry::update_map(const Sweep& sweep) {
  const Eigen::Isometry3d moved = last_insert_T_local_body_.inverse() * T_local_body();
  if (map_inserts_ == 0 || moved.translation().norm() >= config_.map_insert_translation_m ||
      se3::rotation_angle(moved) >= config_.map_insert_rotation_rad) {
    const Eigen::Isometry3f T = T_local_body().cast<float>();
    std::vector<Eigen::Vector3f> world;
    world.reserve(sweep.points_body.size());
    for (const Eigen::Vector3f& p : sweep.points_body) {
      world.push_back(T * p);
    }
    map_.insert(world, (T_local_body() * T_body_lidar_.translation()).cast<float>());
    ++map_inserts_;
    last_insert_T_local_body_ = T_local_body();
  }
  if (++sweeps_since_cleanup_ >= 10) {
    map_.remove_far(x_.p);
    sweeps_since_cleanup_ = 0;
  }
}

std::optional<Keyframe> LidarInertialOdometry::make_keyframe(const Sweep& sweep) {
  const Eigen::Isometry3d delta = last_keyframe_T_local_body_.inverse() * T_local_body();
  if (have_keyframe_ && delta.translation().norm() < config_.keyframe_translation_m &&
      se3::rotation_angle(delta) < config_.keyframe_rotation_rad) {
    return std::nullopt;
  }
  const std::vector<Eigen::Vector3f> full =
      deskew(sweep.valid, sweep.start_utime, sweep.end_utime, sweep.motion, T_body_lidar_);
  PointCloud cloud;
  cloud.reserve(full.size());
  for (size_t i = 0; i < full.size(); ++i) {
    cloud.push_back(full[i], sweep.valid[i].intensity);
  }
  Keyframe kf;
  kf.id = next_keyframe_id_++;
  kf.cloud_body = voxel_downsample(cloud, static_cast<float>(config_.keyframe_voxel_m));
  have_keyframe_ = true;
  last_keyframe_T_local_body_ = T_local_body();
  ++counters_.keyframes;
  return kf;
}

void LidarInertialOdometry::finish_estimate(OdometryEstimate& est) {
  const int64_t end_utime = est.utime_us;
  history_.push_back({end_utime, T_local_body()});
  while (!history_.empty() && history_.front().utime_us < end_utime - to_us(config_.history_s)) {
    history_.pop_front();
  }
  blend_correction();
  imu_.drop_before(end_utime - 1000000);

  est.T_odom_body = T_odom_local_ * T_local_body();
  est.velocity_odom = T_odom_local_.linear() * x_.v;
  est.angular_velocity_body = last_omega_;
  est.gyro_bias = x_.bg;
  est.accel_bias = x_.ba;
  est.covariance = P_.topLeftCorner<6, 6>();
  counters_.lost_scans += est.lost_reason.empty() ? 0 : 1;
  if (lidar_only_) {
    est.extrinsic_check =
        extrinsic_check_->poll(T_body_lidar_.linear(), config_.lidar_time_offset_s);
    if (extrinsic_check_->done()) {
      lidar_only_.reset();
    }
  }
  if (est.keyframe) {
    Keyframe& kf = *est.keyframe;
    kf.utime_us = end_utime;
    kf.T_odom_body = est.T_odom_body;
    kf.velocity_odom = est.velocity_odom;
    kf.gyro_bias = est.gyro_bias;
    kf.accel_bias = est.accel_bias;
    kf.covariance = est.covariance;
    kf.fitness_m = est.fitness_m;
    kf.degenerate = est.degenerate;
    if (config_.use_imu) {
      const BodyGravity gravity = body_gravity(x_, P_);
      kf.gravity_body = gravity.direction;
      kf.gravity_sigma_rad = gravity.sigma_rad;
    }
  }
  ++counters_.scans_processed;
}

std::optional<Eigen::Isometry3d> LidarInertialOdometry::pose_in_history(int64_t utime_us) const {
  if (history_.empty() || utime_us < history_.front().utime_us ||
      utime_us > history_.back().utime_us) {
    return std::nullopt;
  }
  const auto after =
      std::lower_bound(history_.begin(), history_.end(), utime_us,
                       [](const HistoryEntry& e, int64_t t) { return e.utime_us < t; });
  if (after->utime_us == utime_us || after == history_.begin()) {
    return after->T_local_body;
  }
  const auto before = after - 1;
  return se3::interpolate(before->T_local_body, after->T_local_body,
                          static_cast<double>(utime_us - before->utime_us) /
                              static_cast<double>(after->utime_us - before->utime_us));
}

void LidarInertialOdometry::add_correction(const OdometryCorrection& c) {
  const std::optional<Eigen::Isometry3d> T_local_body_then = pose_in_history(c.utime_us);
  const bool finite = (!c.T_odom_body || c.T_odom_body->matrix().allFinite()) &&
                      (!c.velocity_odom || c.velocity_odom->allFinite()) &&
                      (!c.gyro_bias || c.gyro_bias->allFinite()) &&
                      (!c.accel_bias || c.accel_bias->allFinite());
  if (!initialized_ || !T_local_body_then || !finite) {
    ++counters_.corrections_rejected;
    return;
  }
  if (c.T_odom_body) {
    T_odom_local_target_ = *c.T_odom_body * T_local_body_then->inverse();
  }
  // Velocity is only meaningful for the present: from a recent correction only.
  if (c.velocity_odom && state_utime_ - c.utime_us < 500000) {
    x_.v = T_odom_local_.linear().transpose() * *c.velocity_odom;
  }
  if (c.gyro_bias) {
    x_.bg = *c.gyro_bias;
  }
  if (c.accel_bias) {
    x_.ba = *c.accel_bias;
  }
  ++counters_.corrections_applied;
}

void LidarInertialOdometry::blend_correction() {
  if (!T_odom_local_target_) {
    return;
  }
  // Step limits apply to the body's output pose, not to the frame: turning the frame
  // about its origin 100 m away would move the body by 100 m times the angle.
  const Eigen::Isometry3d T_local_body_now = T_local_body();
  const Eigen::Isometry3d body = T_odom_local_ * T_local_body_now;
  const Eigen::Isometry3d body_target = *T_odom_local_target_ * T_local_body_now;
  const Vector6d remaining = se3::log(body.inverse() * body_target);
  if (remaining.head<3>().norm() < 1e-4 && remaining.tail<3>().norm() < 1e-6) {
    T_odom_local_ = *T_odom_local_target_;
    T_odom_local_target_.reset();
    return;
  }
  Vector6d step = config_.correction_blend * remaining;
  const double scale = std::max({1.0, step.head<3>().norm() / config_.correction_max_step_m,
                                 step.tail<3>().norm() / config_.correction_max_step_rad});
  T_odom_local_ = body * se3::exp(step / scale) * T_local_body_now.inverse();
}

}  // namespace liloc
