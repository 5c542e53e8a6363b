#include "eval/trajectory_metrics.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "math/se3.hpp"
#include "math/so3.hpp"

namespace liloc::eval {
namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// TUM files and LCM headers keep microseconds, and at Unix-epoch magnitudes a double
// resolves ~0.2 us: a 10 Hz gap can read 0.1000002 s. Gaps are compared with this slack
// so that ground truth exactly at the limit rate is not dropped.
constexpr double kTimestampSlackS = 1e-6;

std::string format_number(double value) {
  std::ostringstream s;
  s << value;
  return s.str();
}

// The error of segment i -> j: the estimate's relative motion seen from the ground
// truth's, (T_gt_i^-1 T_gt_j)^-1 (T_est_i^-1 T_est_j). Independent of any alignment.
Eigen::Isometry3d relative_error(const PosePair& i, const PosePair& j) {
  const Eigen::Isometry3d T_gt_ij = i.T_gt_body.inverse() * j.T_gt_body;
  const Eigen::Isometry3d T_est_ij = i.T_est_body.inverse() * j.T_est_body;
  return T_gt_ij.inverse() * T_est_ij;
}

// Ground-truth path length from the first matched pose to each one.
std::vector<double> cumulative_gt_distance(const std::vector<PosePair>& pairs) {
  std::vector<double> distance_m(pairs.size(), 0.0);
  for (size_t k = 1; k < pairs.size(); ++k) {
    distance_m[k] =
        distance_m[k - 1] +
        (pairs[k].T_gt_body.translation() - pairs[k - 1].T_gt_body.translation()).norm();
  }
  return distance_m;
}

void add_rpe(const std::vector<PosePair>& pairs, const std::vector<double>& distance_m,
             double segment_m, TrajectoryMetrics& m) {
  double translation_sum = 0.0;
  double rotation_sum = 0.0;
  for (size_t i = 0; i < pairs.size(); ++i) {
    const auto end = std::lower_bound(distance_m.begin() + static_cast<std::ptrdiff_t>(i),
                                      distance_m.end(), distance_m[i] + segment_m);
    if (end == distance_m.end()) {
      break;  // later starts have even less path ahead
    }
    const size_t j = static_cast<size_t>(end - distance_m.begin());
    const double length_m = distance_m[j] - distance_m[i];
    const Eigen::Isometry3d E = relative_error(pairs[i], pairs[j]);
    translation_sum += E.translation().norm() / length_m * 100.0;
    rotation_sum += se3::rotation_angle(E) * so3::kRadToDeg / length_m * 100.0;
    ++m.rpe_segments;
  }
  if (m.rpe_segments == 0) {
    m.rpe_translation_percent = kNaN;
    m.rpe_rotation_deg_per_100m = kNaN;
    m.warnings.push_back("ground-truth path of " + format_number(distance_m.back()) +
                         " m is shorter than one RPE segment of " + format_number(segment_m) +
                         " m: RPE not computed");
    return;
  }
  m.rpe_translation_percent = translation_sum / static_cast<double>(m.rpe_segments);
  m.rpe_rotation_deg_per_100m = rotation_sum / static_cast<double>(m.rpe_segments);
}
}  // namespace

std::string to_string(AlignmentMode mode) {
  switch (mode) {
    case AlignmentMode::kSe3:
      return "se3";
    case AlignmentMode::kFirst:
      return "first";
    case AlignmentMode::kNone:
      return "none";
    case AlignmentMode::kFixed:
      return "fixed";
  }
  return "unknown";
}

AlignmentMode parse_alignment_mode(const std::string& text) {
  for (const AlignmentMode mode :
       {AlignmentMode::kSe3, AlignmentMode::kFirst, AlignmentMode::kNone}) {
    if (text == to_string(mode)) {
      return mode;
    }
  }
  throw std::invalid_argument("unknown alignment '" + text + "' (se3, first, none)");
}

void EvalConfig::validate() const {
  if (!(max_time_gap_s > 0.0)) {
    throw std::invalid_argument("max_time_gap_s must be > 0, got " + format_number(max_time_gap_s));
  }
  if (!(rpe_segment_m > 0.0)) {
    throw std::invalid_argument("rpe_segment_m must be > 0, got " + format_number(rpe_segment_m));
  }
  if (!T_gt_est_fixed.matrix().allFinite()) {
    throw std::invalid_argument("T_gt_est_fixed has a non-finite entry");
  }
}

Association associate(const Trajectory& ground_truth, const Trajectory& estimate,
                      double max_time_gap_s) {
  Association association;
  for (const StampedPose& est : estimate.poses()) {
    if (const auto T_gt_body = ground_truth.at(est.time_s, max_time_gap_s + kTimestampSlackS)) {
      association.pairs.push_back({est.time_s, *T_gt_body, est.T});
    } else {
      ++association.skipped;
    }
  }
  return association;
}

Eigen::Isometry3d fit_rigid_alignment(const std::vector<Eigen::Vector3d>& est_positions,
                                      const std::vector<Eigen::Vector3d>& gt_positions) {
  if (est_positions.empty() || est_positions.size() != gt_positions.size()) {
    throw std::invalid_argument("rigid alignment needs two equally long, non-empty point lists");
  }
  Eigen::Matrix3Xd src(3, est_positions.size());
  Eigen::Matrix3Xd dst(3, gt_positions.size());
  for (size_t k = 0; k < est_positions.size(); ++k) {
    src.col(static_cast<Eigen::Index>(k)) = est_positions[k];
    dst.col(static_cast<Eigen::Index>(k)) = gt_positions[k];
  }
  Eigen::Isometry3d T_gt_est;
  T_gt_est.matrix() = Eigen::umeyama(src, dst, /*with_scaling=*/false);
  return T_gt_est;
}

Eigen::Isometry3d alignment_transform(const Association& association, const EvalConfig& config) {
  if (association.pairs.empty()) {
    throw std::invalid_argument("no matched poses to align");
  }
  switch (config.alignment) {
    case AlignmentMode::kSe3: {
      std::vector<Eigen::Vector3d> est_positions, gt_positions;
      for (const PosePair& pair : association.pairs) {
        est_positions.push_back(pair.T_est_body.translation());
        gt_positions.push_back(pair.T_gt_body.translation());
      }
      return fit_rigid_alignment(est_positions, gt_positions);
    }
    case AlignmentMode::kFirst: {
      const PosePair& first = association.pairs.front();
      return first.T_gt_body * first.T_est_body.inverse();
    }
    case AlignmentMode::kNone:
      return Eigen::Isometry3d::Identity();
    case AlignmentMode::kFixed:
      return config.T_gt_est_fixed;
  }
  throw std::invalid_argument("unknown alignment mode");
}

Trajectory transform_trajectory(const Eigen::Isometry3d& T_gt_est, const Trajectory& estimate) {
  std::vector<StampedPose> poses;
  poses.reserve(estimate.size());
  for (const StampedPose& p : estimate.poses()) {
    poses.push_back({p.time_s, T_gt_est * p.T});
  }
  return Trajectory(std::move(poses));
}

TrajectoryMetrics evaluate_trajectory(const Trajectory& ground_truth, const Trajectory& estimate,
                                      const EvalConfig& config) {
  config.validate();
  Association association = associate(ground_truth, estimate, config.max_time_gap_s);
  if (association.pairs.empty()) {
    throw std::invalid_argument("none of the " + std::to_string(estimate.size()) +
                                " estimate poses has ground truth within " +
                                format_number(config.max_time_gap_s) +
                                " s at its time (are both trajectories on the same clock?)");
  }
  TrajectoryMetrics m;
  m.matched_poses = association.pairs.size();
  m.skipped_poses = association.skipped;
  m.alignment = config.alignment;
  m.T_gt_est = alignment_transform(association, config);
  if (m.skipped_poses > 0) {
    m.warnings.push_back("skipped " + std::to_string(m.skipped_poses) + " of " +
                         std::to_string(estimate.size()) +
                         " estimate poses without ground truth at their time");
  }

  for (PosePair& pair : association.pairs) {
    pair.T_est_body = m.T_gt_est * pair.T_est_body;
  }
  double position_sq = 0.0, full_sq = 0.0, rotation_sq = 0.0;
  for (const PosePair& pair : association.pairs) {
    const Eigen::Isometry3d E = pair.T_gt_body.inverse() * pair.T_est_body;
    const double position_m = E.translation().norm();  // = ||p_est - p_gt||
    const double rotation_deg = se3::rotation_angle(E) * so3::kRadToDeg;
    position_sq += position_m * position_m;
    full_sq += (E.matrix() - Eigen::Matrix4d::Identity()).squaredNorm();
    rotation_sq += rotation_deg * rotation_deg;
    m.ate_position_max_m = std::max(m.ate_position_max_m, position_m);
  }
  const double n = static_cast<double>(m.matched_poses);
  m.ate_position_rmse_m = std::sqrt(position_sq / n);
  m.ate_full_rmse = std::sqrt(full_sq / n);
  m.rotation_rmse_deg = std::sqrt(rotation_sq / n);

  const std::vector<double> distance_m = cumulative_gt_distance(association.pairs);
  m.rpe_segment_m = config.rpe_segment_m;
  add_rpe(association.pairs, distance_m, config.rpe_segment_m, m);
  m.path_length_m = distance_m.back();
  m.duration_s = association.pairs.back().time_s - association.pairs.front().time_s;
  return m;
}

}  // namespace liloc::eval
