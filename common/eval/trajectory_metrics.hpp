#pragma once
// Accuracy of an estimated trajectory against ground truth: association by time,
// alignment of the estimate's frame onto the ground-truth frame, ATE, full-pose error
// (the LiLoc paper's xyz_rpy), rotation error and KITTI-style RPE. Definitions with
// formulas: docs/evaluation.md.

#include <Eigen/Geometry>
#include <cstddef>
#include <string>
#include <vector>

#include "math/trajectory.hpp"

namespace liloc::eval {

enum class AlignmentMode {
  kSe3,    // least-squares rigid fit of the estimate positions onto ground truth
  kFirst,  // the first matched estimate pose onto its ground-truth pose
  kNone,   // the estimate is already in the ground-truth frame
  kFixed,  // a given T_gt_est, e.g. fitted once on the central session A
};

// "se3", "first", "none", "fixed".
std::string to_string(AlignmentMode mode);
// Parses "se3", "first" or "none" (a fixed alignment comes with its transform); throws
// std::invalid_argument naming the value otherwise.
AlignmentMode parse_alignment_mode(const std::string& text);

struct EvalConfig {
  // Ground truth is interpolated at an estimate's time only between poses at most this
  // far apart, so that a gap in the ground truth never invents a reference pose.
  double max_time_gap_s = 0.1;
  // RPE segment length along the ground-truth path (KITTI uses 100 m ... 800 m).
  double rpe_segment_m = 100.0;
  AlignmentMode alignment = AlignmentMode::kSe3;
  // Used when alignment == kFixed. Subsidiary sessions share the central session's map
  // frame, so they are scored with session A's transform, never a refit of their own.
  Eigen::Isometry3d T_gt_est_fixed = Eigen::Isometry3d::Identity();

  // Throws std::invalid_argument naming the field if a value is out of range.
  void validate() const;
};

// An estimate pose and the ground truth interpolated at its time.
struct PosePair {
  double time_s = 0.0;
  Eigen::Isometry3d T_gt_body = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_est_body = Eigen::Isometry3d::Identity();
};

struct Association {
  std::vector<PosePair> pairs;  // in time order
  size_t skipped = 0;           // estimate poses without ground truth at their time
};

// Pairs each estimate pose (time t) with ground_truth.at(t, max_time_gap_s + 1 us): the
// microsecond covers timestamp quantization, so a gap of exactly max_time_gap_s passes.
Association associate(const Trajectory& ground_truth, const Trajectory& estimate,
                      double max_time_gap_s);

// Rigid transform minimizing sum_i ||p_gt_i - T_gt_est * p_est_i||^2, in closed form
// (Umeyama 1991 without scale; the same as Horn's). With fewer than three
// non-collinear points the rotation is not determined and one minimizer is returned.
// Throws std::invalid_argument if the lists are empty or differ in size.
Eigen::Isometry3d fit_rigid_alignment(const std::vector<Eigen::Vector3d>& est_positions,
                                      const std::vector<Eigen::Vector3d>& gt_positions);

// T_gt_est for the configured alignment mode; throws std::invalid_argument if the
// association is empty.
Eigen::Isometry3d alignment_transform(const Association& association, const EvalConfig& config);

// T_gt_est * T_est_body for every pose: the estimate expressed in the ground-truth frame.
Trajectory transform_trajectory(const Eigen::Isometry3d& T_gt_est, const Trajectory& estimate);

struct TrajectoryMetrics {
  size_t matched_poses = 0;
  size_t skipped_poses = 0;
  AlignmentMode alignment = AlignmentMode::kSe3;
  Eigen::Isometry3d T_gt_est = Eigen::Isometry3d::Identity();  // the transform applied

  double ate_position_rmse_m = 0.0;  // RMSE of ||p_gt - p_est||
  double ate_position_max_m = 0.0;   // largest ||p_gt - p_est||
  double ate_full_rmse = 0.0;        // xyz_rpy: RMSE of ||T_gt^-1 T_est - I_4||_F, unit-less
  double rotation_rmse_deg = 0.0;    // RMSE of angle(R_gt^T R_est)

  // KITTI-style relative error over segments of rpe_segment_m of ground-truth path;
  // NaN (and rpe_segments == 0) when the path is shorter than one segment.
  size_t rpe_segments = 0;
  double rpe_segment_m = 0.0;
  double rpe_translation_percent = 0.0;    // mean of |t(E)| / L * 100
  double rpe_rotation_deg_per_100m = 0.0;  // mean of angle(E) / L * 100 m

  double path_length_m = 0.0;  // ground-truth path over the matched poses
  double duration_s = 0.0;     // from the first to the last matched pose

  // Why a number is missing or what was left out, for the user and the JSON.
  std::vector<std::string> warnings;
};

// Associates, aligns and scores. Throws std::invalid_argument if the config is invalid
// or no estimate pose has ground truth at its time.
TrajectoryMetrics evaluate_trajectory(const Trajectory& ground_truth, const Trajectory& estimate,
                                      const EvalConfig& config);

}  // namespace liloc::eval
