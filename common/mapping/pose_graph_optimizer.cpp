#include "mapping/pose_graph_optimizer.hpp"

#include <ceres/loss_function.h>
#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include <map>
#include <stdexcept>

#include "factors/relative_pose_factor.hpp"
#include "factors/se3_manifold.hpp"

namespace liloc {

void PoseGraphConfig::validate() const {
  if (max_iterations < 1 || !(loop_loss_scale > 0) || threads < 1 || threads > 64) {
    throw std::invalid_argument(
        "max_iterations must be at least 1, loop_loss_scale positive, threads 1 to 64");
  }
}

PoseGraphResult optimize_pose_graph(std::vector<MapKeyframe>& keyframes,
                                    const std::vector<PoseGraphEdge>& edges,
                                    const PoseGraphConfig& config) {
  PoseGraphResult result;
  if (keyframes.size() < 2 || edges.empty()) {
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
  result.iterations = static_cast<int>(summary.iterations.size());
  result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.solve_s = summary.total_time_in_seconds;
  return result;
}

}  // namespace liloc
