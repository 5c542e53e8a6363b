#include "mapping/pose_graph_optimizer.hpp"

#include <ceres/loss_function.h>
#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <map>
#include <stdexcept>

#include "factors/gravity_factor.hpp"
#include "factors/relative_pose_factor.hpp"
#include "factors/se3_manifold.hpp"

namespace liloc {

void PoseGraphConfig::validate() const {
  if (max_iterations < 1 || !(loop_loss_scale > 0) || threads < 1 || threads > 64 ||
      !(gravity_sigma_rad > 0) || !(gravity_max_sigma_rad > 0)) {
    throw std::invalid_argument(
        "max_iterations must be at least 1, loop_loss_scale and the gravity sigmas positive, "
        "threads 1 to 64");
  }
}

namespace {

double sigma_of(const GravityObservation& g, const PoseGraphConfig& config) {
  return std::hypot(g.sigma_rad, config.gravity_sigma_rad);
}

// The down direction a gravity observation gives in the map frame, at its keyframe's pose.
Eigen::Vector3d down_in_map(const std::vector<MapKeyframe>& keyframes,
                            const std::map<int64_t, size_t>& index, const GravityObservation& g) {
  const auto it = index.find(g.keyframe_id);
  if (it == index.end()) {
    throw std::invalid_argument("gravity observation names the missing keyframe " +
                                std::to_string(g.keyframe_id));
  }
  return keyframes[it->second].T_map_body.linear() * g.down_body;
}

// The map's down: the observations' mean in the map frame, each weighted by its
// information.
Eigen::Vector3d mean_down(const std::vector<MapKeyframe>& keyframes,
                          const std::map<int64_t, size_t>& index,
                          const std::vector<GravityObservation>& gravity,
                          const PoseGraphConfig& config) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const GravityObservation& g : gravity) {
    sum += down_in_map(keyframes, index, g) / std::pow(sigma_of(g, config), 2);
  }
  return sum.normalized();
}

double max_tilt(const std::vector<MapKeyframe>& keyframes, const std::map<int64_t, size_t>& index,
                const std::vector<GravityObservation>& gravity, const Eigen::Vector3d& down_map) {
  double worst = 0.0;
  for (const GravityObservation& g : gravity) {
    const Eigen::Vector3d d = down_in_map(keyframes, index, g);
    worst = std::max(worst, std::atan2(d.cross(down_map).norm(), d.dot(down_map)));
  }
  return worst;
}

}  // namespace

PoseGraphResult optimize_pose_graph(std::vector<MapKeyframe>& keyframes,
                                    const std::vector<PoseGraphEdge>& edges,
                                    const PoseGraphConfig& config,
                                    const std::vector<GravityObservation>& observations) {
  PoseGraphResult result;
  if (keyframes.size() < 2) {
    result.converged = true;
    return result;
  }
  std::vector<GravityObservation> gravity;
  if (config.level_by_gravity) {
    // The first keyframe is held: it anchors the map frame, gravity does not move it.
    std::copy_if(observations.begin(), observations.end(), std::back_inserter(gravity),
                 [&](const GravityObservation& g) {
                   return g.sigma_rad <= config.gravity_max_sigma_rad &&
                          g.keyframe_id != keyframes.front().id;
                 });
  }
  const bool level = !gravity.empty();
  if (edges.empty() && !level) {
    result.converged = true;
    return result;
  }
  // Parameter blocks: one pose per keyframe (Se3Manifold).
  std::vector<PoseBlock> nodes(keyframes.size());
  std::map<int64_t, size_t> index;
  for (size_t i = 0; i < keyframes.size(); ++i) {
    nodes[i] = pose_block(keyframes[i].T_map_body);
    index[keyframes[i].id] = i;
  }
  ceres::Problem problem;  // owns the manifold, costs and losses
  ceres::Manifold* manifold = new Se3Manifold;
  for (const PoseGraphEdge& e : edges) {
    const auto a = index.find(e.from);
    const auto b = index.find(e.to);
    if (a == index.end() || b == index.end()) {
      throw std::invalid_argument("pose graph edge " + std::to_string(e.from) + " -> " +
                                  std::to_string(e.to) + " names a missing keyframe");
    }
    const Matrix6d sqrt_information = e.information.llt().matrixU();
    ceres::LossFunction* loss = e.kind == PoseGraphEdge::Kind::kLoop
                                    ? new ceres::CauchyLoss(config.loop_loss_scale)
                                    : nullptr;
    problem.AddResidualBlock(RelativePoseFactor::create(e.T_from_to, sqrt_information), loss,
                             nodes[a->second].data(), nodes[b->second].data());
  }
  Eigen::Vector3d down_map = Eigen::Vector3d::Zero();
  if (level) {
    down_map = mean_down(keyframes, index, gravity, config);  // throws on a missing keyframe
    result.max_tilt_before_rad = max_tilt(keyframes, index, gravity, down_map);
    for (const GravityObservation& g : gravity) {
      problem.AddResidualBlock(GravityFactor::create(down_map, g.down_body, sigma_of(g, config)),
                               nullptr, nodes[index.at(g.keyframe_id)].data());
    }
    result.gravity_factors = static_cast<int>(gravity.size());
  }
  for (PoseBlock& n : nodes) {
    if (problem.HasParameterBlock(n.data())) {
      problem.SetManifold(n.data(), manifold);
    }
  }
  // The first keyframe anchors the map frame.
  if (problem.HasParameterBlock(nodes[0].data())) {
    problem.SetParameterBlockConstant(nodes[0].data());
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.max_num_iterations = config.max_iterations;
  options.num_threads = config.threads;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  for (size_t i = 0; i < keyframes.size(); ++i) {
    keyframes[i].T_map_body = pose_of(nodes[i].data());
  }
  if (level) {
    result.max_tilt_after_rad = max_tilt(keyframes, index, gravity, down_map);
    const Eigen::Quaterniond turn =
        Eigen::Quaterniond::FromTwoVectors(down_map, -Eigen::Vector3d::UnitZ());
    result.frame_turn_rad = turn.angularDistance(Eigen::Quaterniond::Identity());
    const Eigen::Isometry3d T_level_map(turn);
    for (MapKeyframe& kf : keyframes) {
      kf.T_map_body = T_level_map * kf.T_map_body;
    }
  }
  result.iterations = static_cast<int>(summary.iterations.size());
  result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.solve_s = summary.total_time_in_seconds;
  return result;
}

}  // namespace liloc
