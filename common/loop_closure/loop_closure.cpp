#include "loop_closure/loop_closure.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "math/so3.hpp"
#include "math/stopwatch.hpp"
#include "pointcloud/voxel_grid.hpp"

namespace liloc {
namespace {

constexpr double kPi = 3.141592653589793;

std::vector<Eigen::Vector3f> transformed(const std::vector<Eigen::Vector3f>& points,
                                         const Eigen::Isometry3f& T) {
  std::vector<Eigen::Vector3f> out;
  out.reserve(points.size());
  for (const Eigen::Vector3f& p : points) {
    out.push_back(T * p);
  }
  return out;
}

}  // namespace

void LoopClosureConfig::validate() const {
  if (!(search_radius_m > 0.0) || !(min_time_gap_s >= 0.0) || !(verify_voxel_m > 0.0) ||
      !(max_fitness_m > 0.0)) {
    throw std::invalid_argument(
        "search_radius_m, verify_voxel_m and max_fitness_m must be positive, min_time_gap_s "
        "not negative");
  }
  if (!(max_descriptor_distance >= 0.0 && max_descriptor_distance <= 1.0) ||
      !(min_matched_fraction >= 0.0 && min_matched_fraction <= 1.0)) {
    throw std::invalid_argument(
        "max_descriptor_distance and min_matched_fraction must be within 0 .. 1");
  }
  if (candidates < 1 || local_map_half_window < 0 || min_correspondences < 6 ||
      independent_correspondences < 1) {
    throw std::invalid_argument(
        "candidates and independent_correspondences must be at least 1, min_correspondences "
        "at least 6, local_map_half_window not negative");
  }
  if (!(map_sigma_translation_m >= 0.0) || !(map_sigma_rotation_rad >= 0.0) ||
      !(max_drift_fraction >= 0.0) || !(correction_floor_m >= 0.0) ||
      !(max_rotation_drift_rad_per_m >= 0.0) || !(correction_floor_rad >= 0.0)) {
    throw std::invalid_argument("sigmas, drift rates and correction floors must not be negative");
  }
  registration.validate();
  target_map.validate();
}

LoopClosureDetector::LoopClosureDetector(const LoopClosureConfig& config,
                                         const PolarDescriptorConfig& descriptor)
    : config_(config), descriptor_(descriptor) {
  config_.validate();
  descriptor_.validate();
}

std::vector<LoopClosure> LoopClosureDetector::add(const MapKeyframe& keyframe,
                                                  const PointCloud& cloud_body) {
  if (!keyframes_.empty() && keyframe.utime_us <= keyframes_.back().utime_us) {
    throw std::invalid_argument("loop closure: keyframe " + std::to_string(keyframe.id) +
                                " is not newer than keyframe " +
                                std::to_string(keyframes_.back().id));
  }
  if (std::any_of(keyframes_.begin(), keyframes_.end(),
                  [&](const Stored& s) { return s.id == keyframe.id; })) {
    throw std::invalid_argument("loop closure: keyframe id " + std::to_string(keyframe.id) +
                                " was added before");
  }
  ++stats_.keyframes;
  const Stopwatch descriptor_watch;
  Stored query;
  query.id = keyframe.id;
  query.utime_us = keyframe.utime_us;
  query.T_map_body = keyframe.T_map_body;
  query.path_m = keyframes_.empty()
                     ? 0.0
                     : keyframes_.back().path_m + (keyframe.T_map_body.translation() -
                                                   keyframes_.back().T_map_body.translation())
                                                      .norm();
  // Levelled: on a slope the body's own frame would tilt far cells by metres.
  query.descriptor =
      make_level_polar_descriptor(cloud_body, keyframe.T_map_body.linear(), descriptor_);
  query.points_body =
      voxel_downsample(cloud_body, static_cast<float>(config_.verify_voxel_m)).points;

  // Keyframes [0, old_end) are at least min_time_gap_s older: candidates, and the only
  // ones a target map may contain.
  const int64_t newest_old_us =
      keyframe.utime_us - static_cast<int64_t>(std::llround(config_.min_time_gap_s * 1e6));
  const size_t old_end = static_cast<size_t>(
      std::partition_point(keyframes_.begin(), keyframes_.end(),
                           [&](const Stored& s) { return s.utime_us <= newest_old_us; }) -
      keyframes_.begin());
  const std::vector<Candidate> candidates = select_candidates(query, old_end);
  stats_.descriptor_ms += descriptor_watch.ms();

  std::vector<LoopClosure> closures;
  for (const Candidate& candidate : candidates) {
    const Stopwatch verify_watch;
    LoopClosure closure;
    if (verify(query, candidate, old_end, closure)) {
      closures.push_back(closure);
    }
    stats_.verification_ms += verify_watch.ms();
  }
  keyframes_.push_back(std::move(query));
  return closures;
}

std::vector<LoopClosureDetector::Candidate> LoopClosureDetector::select_candidates(
    const Stored& query, size_t old_end) {
  // The best descriptor match of each earlier pass through the search radius (a run of
  // consecutive nearby keyframes): a pass gives at most one closure, as its other
  // keyframes would be verified against nearly the same target map.
  std::vector<Candidate> best_of_pass;
  size_t pass = 0;
  bool in_pass = false;
  for (size_t i = 0; i < old_end; ++i) {
    const Stored& s = keyframes_[i];
    if ((s.T_map_body.translation() - query.T_map_body.translation()).norm() >
        config_.search_radius_m) {
      in_pass = false;
      continue;
    }
    ++stats_.nearby;
    if (!in_pass) {
      ++pass;
      in_pass = true;
    }
    const DescriptorMatch match = compare(query.descriptor, s.descriptor);
    if (match.distance > config_.max_descriptor_distance) {
      ++stats_.rejected_descriptor;
      continue;
    }
    if (best_of_pass.empty() || best_of_pass.back().pass != pass) {
      best_of_pass.push_back({i, pass, match});
    } else if (match.distance < best_of_pass.back().match.distance) {
      best_of_pass.back() = {i, pass, match};
    }
  }
  std::sort(best_of_pass.begin(), best_of_pass.end(), [](const Candidate& a, const Candidate& b) {
    return a.match.distance != b.match.distance ? a.match.distance < b.match.distance
                                                : a.index < b.index;
  });
  if (best_of_pass.size() > static_cast<size_t>(config_.candidates)) {
    best_of_pass.resize(config_.candidates);
  }
  return best_of_pass;
}

bool LoopClosureDetector::verify(const Stored& query, const Candidate& candidate, size_t old_end,
                                 LoopClosure& closure) {
  ++stats_.tried;
  const Stored& target = keyframes_[candidate.index];
  const Eigen::Isometry3d T_target_map = target.T_map_body.inverse();

  // The candidate and its neighbours, placed by their estimated poses, in the candidate's
  // body frame: the registration then measures T_from_to directly.
  VoxelHashMap map(config_.target_map);
  const size_t window = static_cast<size_t>(config_.local_map_half_window);
  const size_t first = candidate.index > window ? candidate.index - window : 0;
  const size_t last = std::min(old_end, candidate.index + window + 1);
  for (size_t n = first; n < last; ++n) {
    map.insert(transformed(keyframes_[n].points_body,
                           (T_target_map * keyframes_[n].T_map_body).cast<float>()));
  }

  // Start from the odometry's relative pose. Its heading is finer than a sector, so the
  // descriptor's yaw replaces it only where the two disagree by more than a sector: the
  // heading drifted further than the descriptor can resolve.
  const Eigen::Isometry3d T_target_query_odom = T_target_map * query.T_map_body;
  Eigen::Isometry3d T_map_query_start = query.T_map_body;
  const double odom_yaw =
      so3::yaw(query.T_map_body.linear()) - so3::yaw(target.T_map_body.linear());
  const double yaw_error = so3::wrap_angle(candidate.match.yaw_rad - odom_yaw);
  if (std::abs(yaw_error) > 2.0 * kPi / descriptor_.sectors) {
    ++stats_.yaw_refined;
    T_map_query_start.linear() =
        Eigen::AngleAxisd(yaw_error, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
        query.T_map_body.linear();
  }
  const RegistrationResult result = register_point_to_plane(
      query.points_body, map, T_target_map * T_map_query_start, std::nullopt, config_.registration);

  if (result.correspondences < config_.min_correspondences ||
      result.correspondences <
          config_.min_matched_fraction * static_cast<double>(query.points_body.size())) {
    ++stats_.rejected_correspondences;
    return false;
  }
  if (result.degenerate) {
    ++stats_.rejected_degenerate;
    return false;
  }
  if (result.rms_residual_m > config_.max_fitness_m) {
    ++stats_.rejected_fitness;
    return false;
  }
  const Eigen::Isometry3d correction = T_target_query_odom.inverse() * result.T_target_source;
  const double travelled_m = query.path_m - target.path_m;
  if (correction.translation().norm() >
          config_.correction_floor_m + config_.max_drift_fraction * travelled_m ||
      se3::rotation_angle(correction) >
          config_.correction_floor_rad + config_.max_rotation_drift_rad_per_m * travelled_m) {
    ++stats_.rejected_implausible;
    return false;
  }

  // Covariance: the registration's, as if from independent_correspondences independent
  // matches, plus the target map's own inconsistency.
  // Over the right perturbation of T_from_to.
  Matrix6d covariance =
      result.independent_information(config_.independent_correspondences).inverse();
  covariance.diagonal().head<3>().array() +=
      config_.map_sigma_translation_m * config_.map_sigma_translation_m;
  covariance.diagonal().tail<3>().array() +=
      config_.map_sigma_rotation_rad * config_.map_sigma_rotation_rad;
  const Matrix6d information = covariance.inverse();

  ++stats_.verified;
  closure.from_id = target.id;
  closure.to_id = query.id;
  closure.T_from_to = result.T_target_source;
  closure.information = 0.5 * (information + information.transpose());
  closure.fitness_m = result.rms_residual_m;
  closure.descriptor_distance = candidate.match.distance;
  return true;
}

}  // namespace liloc
