#include "optimizer/localizer.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "math/stopwatch.hpp"
#include "pointcloud/voxel_grid.hpp"

namespace liloc {
void LocalizerConfig::validate() const {
  graph.validate();
  if (!(overlap_half_side_m > 0) || !(overlap_threshold > 0 && overlap_threshold <= 1) ||
      overlap_submaps < 1 || !(target_radius_m > 0) || max_query_points < 100 ||
      !(max_fitness_m > 0) || !(min_matched_ratio >= 0 && min_matched_ratio <= 1) ||
      !(max_correction_m > 0) || !(max_correction_rad > 0) || !(prior_fitness_radius_m > 0) ||
      !(fitness_cap_m > 0) || !(target_prefetch_m >= 0) ||
      !(target_keep_m > target_radius_m + target_prefetch_m) || independent_correspondences < 1) {
    throw std::invalid_argument(
        "the localizer's distances and bounds must be positive, overlap_threshold and "
        "min_matched_ratio in [0, 1], max_query_points at least 100, "
        "independent_correspondences at least 1, target_keep_m "
        "beyond target_radius_m + target_prefetch_m");
  }
  stages.validate();
  registration.validate();
}

namespace {
const LocalizerConfig& validated(const LocalizerConfig& config) {
  config.validate();
  return config;
}
}  // namespace

Localizer::Localizer(const LocalizerConfig& config, const MapIndex& index,
                     const SubmapTargets& targets)
    : config_(validated(config)),
      index_(&index),
      targets_(targets),
      graph_(config.graph),
      target_(config.stages.voxel_m, config.target_radius_m, config.target_prefetch_m,
              config.target_keep_m) {}

void Localizer::start(const LocalizerKeyframe& keyframe, const Eigen::Isometry3d& T_map_body,
                      const Matrix6d& covariance) {
  GraphKeyframe first;
  first.id = keyframe.id;
  first.utime_us = keyframe.utime_us;
  first.T_odom_body = keyframe.T_odom_body;
  first.odometry_covariance = keyframe.odometry_covariance;
  graph_.start(first, T_map_body, covariance);
  T_map_odom_ = T_map_body * keyframe.T_odom_body.inverse();
  position_map_ = T_map_body.translation();
  started_ = true;
}

double Localizer::upkeep() {
  const Stopwatch watch;
  if (started_) {
    target_.prefetch(*index_, targets_, position_map_);
  }
  return watch.ms();
}

Eigen::Isometry3d Localizer::T_map_odom() const {
  return config_.scan_to_map_only ? T_map_odom_ : graph_.T_map_odom();
}

double Localizer::overlap(const Eigen::Vector3d& position) const {
  double best = 0.0;
  for (const KdTree::Hit& hit :
       index_->submaps().nearest_submaps(position, static_cast<size_t>(config_.overlap_submaps))) {
    if (const Submap* submap = index_->submaps().submap(hit.id)) {
      best = std::max(best, overlap_ratio(position, config_.overlap_half_side_m, submap->bounds));
    }
  }
  return best;
}

std::optional<ScanMatch> Localizer::scan_match(const LocalizerKeyframe& keyframe,
                                               const Eigen::Isometry3d& T_predicted,
                                               LocalizerOutput& out) {
  const Stopwatch target_watch;
  SlidingTarget::Update update = target_.update(*index_, targets_, T_predicted.translation());
  out.target_ms = target_watch.ms();
  out.missing_submaps = std::move(update.missing);
  out.upcoming_submaps = std::move(update.upcoming);
  if (!out.missing_submaps.empty()) {
    out.gate = "waiting for " + std::to_string(out.missing_submaps.size()) + " submap(s)";
    return std::nullopt;
  }
  Eigen::Isometry3d T = T_predicted;
  RegistrationResult result;
  std::vector<Eigen::Vector3f> points;
  const VoxelHashMap* finest = nullptr;
  for (size_t s = 0; s < config_.stages.size(); ++s) {
    points = sparse_points(keyframe.cloud_body, static_cast<float>(config_.stages.voxel_m[s]),
                           static_cast<size_t>(config_.max_query_points));
    finest = &target_.stage(s);
    result = register_point_to_plane(points, *finest, T, std::nullopt,
                                     config_.stages.stage(s, config_.registration));
    T = result.T_target_source;
  }
  out.fitness_m = result.rms_residual_m;
  out.degenerate = result.degenerate;
  const double matched =
      points.empty() ? 0.0 : static_cast<double>(result.correspondences) / points.size();
  // A degenerate registration (a corridor) may slide along its weak axis: that part of the
  // correction is not gated (its factors carry only the little the registration knows
  // there, ScanMatch::information).
  const Matrix6d constrained =
      result.degenerate
          ? constrained_directions(result.information, config_.registration.degeneracy_ratio)
          : Matrix6d::Identity();
  const Vector6d correction = constrained * se3::minus(T, T_predicted);
  // Gates: a registration that did not converge on the map, or that moves the estimate
  // further than the odometry can have drifted, is not a measurement.
  if (!(result.rms_residual_m <= config_.max_fitness_m)) {
    out.gate = "fitness " + std::to_string(result.rms_residual_m) + " m";
  } else if (matched < config_.min_matched_ratio) {
    out.gate = "matched " + std::to_string(matched);
  } else if (correction.head<3>().norm() > config_.max_correction_m ||
             correction.tail<3>().norm() > config_.max_correction_rad) {
    out.gate = "correction " + std::to_string(correction.head<3>().norm()) + " m";
  }
  if (!out.gate.empty()) {
    return std::nullopt;
  }
  ScanMatch match;
  match.T_map_body = T;
  match.fitness_m = result.rms_residual_m;
  match.information = result.independent_information(config_.independent_correspondences);
  // Eq. 8, propagation: the N_d nearest prior nodes (Tree_p), each with the fitness of the
  // keyframe's points around it.
  const Eigen::Isometry3f Tf = T.cast<float>();
  const float cap = static_cast<float>(config_.fitness_cap_m);
  for (const KdTree::Hit& hit : index_->submaps().nearest_keyframes(
           T.translation(), static_cast<size_t>(config_.graph.prior_nodes))) {
    const MapKeyframe* kf = index_->submaps().keyframe(hit.id);
    if (kf == nullptr) {
      continue;
    }
    const Eigen::Vector3f center = kf->T_map_body.translation().cast<float>();
    double sum = 0.0;
    int count = 0;
    for (const Eigen::Vector3f& p : points) {
      const Eigen::Vector3f q = Tf * p;
      if ((q - center).norm() > config_.prior_fitness_radius_m) {
        continue;
      }
      const Neighbors<1> nearest = finest->nearest<1>(q, cap);
      sum += nearest.count > 0 ? nearest.squared_distances[0] : cap * cap;
      ++count;
    }
    match.prior_nodes.push_back(
        {kf->id, kf->T_map_body, count > 0 ? std::sqrt(sum / count) : config_.fitness_cap_m});
  }
  return match;
}

LocalizerOutput Localizer::add(const LocalizerKeyframe& keyframe) {
  if (!started_) {
    throw std::logic_error("Localizer::add before start");
  }
  const Stopwatch watch;
  LocalizerOutput out;
  const Eigen::Isometry3d T_predicted = T_map_odom() * keyframe.T_odom_body;
  out.overlap = overlap(T_predicted.translation());
  const bool inside = config_.no_mode_switch || out.overlap >= config_.overlap_threshold;
  out.mode = !config_.ilm_only && inside ? LocalizationMode::kRelocalization
                                         : LocalizationMode::kIncremental;
  GraphKeyframe kf;
  kf.id = keyframe.id;
  kf.utime_us = keyframe.utime_us;
  kf.T_odom_body = keyframe.T_odom_body;
  kf.odometry_covariance = keyframe.odometry_covariance;
  kf.imu = keyframe.imu;
  if (out.mode == LocalizationMode::kRelocalization) {
    const Stopwatch match_watch;
    kf.scan_match = scan_match(keyframe, T_predicted, out);
    out.scan_match_ms = match_watch.ms();
    out.scan_matched = kf.scan_match.has_value();
    if (kf.scan_match) {
      out.T_map_body_registered = kf.scan_match->T_map_body;
    }
  }
  if (config_.scan_to_map_only) {
    // HDL-Loc style: the registration's pose when it passed, else the odometry carries on.
    out.T_map_body = kf.scan_match ? kf.scan_match->T_map_body : T_predicted;
    T_map_odom_ = out.T_map_body * keyframe.T_odom_body.inverse();
  } else {
    graph_.set_mode(out.mode);
    out.graph = graph_.add(kf);
    out.T_map_body = out.graph.T_map_body;
  }
  position_map_ = out.T_map_body.translation();
  out.total_ms = watch.ms();
  return out;
}

}  // namespace liloc
