#include "mapping/central_session_builder.hpp"

#include <cmath>
#include <stdexcept>

#include "map/map_validation.hpp"

namespace liloc {

void CentralSessionConfig::validate() const {
  if (!is_valid_name(session)) {
    throw std::invalid_argument(
        "session '" + session +
        "' must be 1-64 characters without ',', '\"' or control characters");
  }
  if (!(odometry_translation_sigma_m > 0) || !(odometry_rotation_sigma_rad > 0) ||
      !(odometry_drift_fraction >= 0)) {
    throw std::invalid_argument(
        "odometry sigmas must be positive and odometry_drift_fraction not negative");
  }
  loops.validate();
  graph.validate();
}

CentralSessionBuilder::CentralSessionBuilder(const CentralSessionConfig& config,
                                             const SubmapConfig& submaps,
                                             const PolarDescriptorConfig& descriptor)
    : config_(config), submaps_(submaps), loops_(config.loops, descriptor) {
  config_.validate();
  submaps_.validate();
}

void CentralSessionBuilder::add(const Keyframe& keyframe) {
  MapKeyframe kf;
  kf.id = static_cast<int64_t>(keyframes_.size());
  kf.utime_us = keyframe.utime_us;
  kf.session = config_.session;
  kf.T_map_body = keyframe.T_odom_body;
  kf.fitness_m = keyframe.fitness_m;
  if (!keyframes_.empty()) {
    const MapKeyframe& previous = keyframes_.back();
    PoseGraphEdge e;
    e.from = previous.id;
    e.to = kf.id;
    e.T_from_to = previous.T_map_body.inverse() * kf.T_map_body;
    const double sigma_t = config_.odometry_translation_sigma_m +
                           config_.odometry_drift_fraction * e.T_from_to.translation().norm();
    Vector6d information;
    information << Eigen::Vector3d::Constant(1.0 / (sigma_t * sigma_t)),
        Eigen::Vector3d::Constant(1.0 / std::pow(config_.odometry_rotation_sigma_rad, 2));
    e.information = information.asDiagonal();
    e.kind = PoseGraphEdge::Kind::kOdometry;
    edges_.push_back(e);
  }
  if (config_.close_loops) {
    for (const LoopClosure& c : loops_.add(kf, keyframe.cloud_body)) {
      PoseGraphEdge e;
      e.from = c.from_id;
      e.to = c.to_id;
      e.T_from_to = c.T_from_to;
      e.information = c.information;
      e.kind = PoseGraphEdge::Kind::kLoop;
      edges_.push_back(e);
      ++loop_closures_;
    }
  }
  // Without an IMU the odometry sends no gravity; a malformed one is left out the same way.
  const double norm = keyframe.gravity_body.norm();
  if (std::abs(norm - 1.0) < 1e-3 && std::isfinite(keyframe.gravity_sigma_rad) &&
      keyframe.gravity_sigma_rad >= 0) {
    gravity_.push_back({kf.id, keyframe.gravity_body / norm, keyframe.gravity_sigma_rad});
  }
  clouds_[kf.id] = keyframe.cloud_body;
  keyframes_.push_back(kf);
}

MapData CentralSessionBuilder::build(std::map<int64_t, PointCloud>* clouds,
                                     CentralSessionReport* report) {
  MapData map;
  map.keyframes = std::move(keyframes_);
  map.edges = std::move(edges_);
  const PoseGraphResult graph =
      optimize_pose_graph(map.keyframes, map.edges, config_.graph, gravity_);
  map.submaps = join_submaps(map.keyframes, submaps_, 0);
  if (report != nullptr) {
    report->keyframes = map.keyframes.size();
    report->loop_closures = loop_closures_;
    report->graph = graph;
    report->submaps = map.submaps.size();
  }
  *clouds = std::move(clouds_);
  return map;
}

}  // namespace liloc
