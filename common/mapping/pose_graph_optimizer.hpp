#pragma once
// Pose-graph optimization of a map's keyframes with Ceres: odometry edges between
// consecutive keyframes and loop edges, the first keyframe held fixed (it anchors the
// map frame). Loop edges go through a Cauchy loss, so that a wrong closure that slipped
// through verification bends the map less. Gravity factors (factors/gravity_factor.hpp)
// level the keyframes against the mean down direction of the drive: a map whose attitude
// wanders against gravity from place to place misleads every IMU that localizes in it.
// Then the frame is turned about its origin so that this down is -z: the map frame of the
// odometry's first sweep is levelled only by the accelerometer's mean over its start
// (1-1.6 degrees off on the simulated campus, where the drive starts moving), and users of
// a map take its z axis for up (heights, renders, other localizers).

#include <vector>

#include "map/map_types.hpp"

namespace liloc {

struct PoseGraphConfig {
  int max_iterations = 100;
  double loop_loss_scale = 1.0;  // Cauchy scale on whitened loop residuals
  int threads = 1;
  bool level_by_gravity = true;
  // Added in quadrature to each observation's own sigma: the map's attitude against
  // gravity is trusted to this, whatever the filter claims (after convergence the filter
  // claims 0.4 mrad and is 0.9 mrad off, median, HDL-32E campus A).
  double gravity_sigma_rad = 0.002;
  // Observations less certain than this are left out. Until the first turns tell the
  // accelerometer bias from tilt, the filter's gravity is 15-19 mrad off while it claims
  // 7-10 mrad: weighted by that claim they bent the start of the map (ATE 0.057 -> 0.095 m).
  double gravity_max_sigma_rad = 0.002;

  template <class V>
  void visit_fields(V& v) {
    v("max_iterations", max_iterations);
    v("loop_loss_scale", loop_loss_scale);
    v("threads", threads);
    v("level_by_gravity", level_by_gravity);
    v("gravity_sigma_rad", gravity_sigma_rad);
    v("gravity_max_sigma_rad", gravity_max_sigma_rad);
  }
  void validate() const;
};

// The down direction at a keyframe, in its body frame, as the odometry's filter estimated
// it (unit vector, 1-sigma angle in rad).
struct GravityObservation {
  int64_t keyframe_id = 0;
  Eigen::Vector3d down_body = Eigen::Vector3d::Zero();
  double sigma_rad = 0.0;
};

struct PoseGraphResult {
  int iterations = 0;
  double initial_cost = 0.0;
  double final_cost = 0.0;
  bool converged = false;
  double solve_s = 0.0;
  int gravity_factors = 0;
  // Largest angle between a keyframe's down and the map's, before and after (rad).
  double max_tilt_before_rad = 0.0;
  double max_tilt_after_rad = 0.0;
  double frame_turn_rad = 0.0;  // the turn that put the map's down on -z
};

// Optimizes keyframes[i].T_map_body in place. Edges and gravity observations must name
// existing keyframe ids; throws std::invalid_argument otherwise.
PoseGraphResult optimize_pose_graph(std::vector<MapKeyframe>& keyframes,
                                    const std::vector<PoseGraphEdge>& edges,
                                    const PoseGraphConfig& config,
                                    const std::vector<GravityObservation>& gravity = {});

}  // namespace liloc
