#pragma once
// Pose-graph optimization of a map's keyframes with Ceres: odometry edges between
// consecutive keyframes and loop edges, the first keyframe held fixed (it anchors the
// map frame). Loop edges go through a Cauchy loss, so that a wrong closure that slipped
// through verification bends the map less.

#include <vector>

#include "map/map_types.hpp"

namespace liloc {

struct PoseGraphConfig {
  int max_iterations = 100;
  double loop_loss_scale = 1.0;  // Cauchy scale on whitened loop residuals
  int threads = 1;

  template <class V>
  void visit_fields(V& v) {
    v("max_iterations", max_iterations);
    v("loop_loss_scale", loop_loss_scale);
    v("threads", threads);
  }
  void validate() const;
};

struct PoseGraphResult {
  int iterations = 0;
  double initial_cost = 0.0;
  double final_cost = 0.0;
  bool converged = false;
  double solve_s = 0.0;
};

// Optimizes keyframes[i].T_map_body in place. Edges must name existing keyframe ids;
// throws std::invalid_argument otherwise.
PoseGraphResult optimize_pose_graph(std::vector<MapKeyframe>& keyframes,
                                    const std::vector<PoseGraphEdge>& edges,
                                    const PoseGraphConfig& config);

}  // namespace liloc
