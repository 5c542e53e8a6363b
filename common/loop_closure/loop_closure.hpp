#pragma once
// Loop closure for building one consistent central session from a drive: each new
// keyframe is compared with earlier keyframes near its estimated position (polar
// descriptor, paper Eqs. 3-4), and the best candidates are verified by registering the
// keyframe to a local map around the candidate (point-to-plane, Eq. 6). A verified
// closure is a relative pose with its information, an edge for the pose graph.

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "descriptor/polar_descriptor.hpp"
#include "map/map_types.hpp"
#include "math/se3.hpp"
#include "pointcloud/point_cloud.hpp"
#include "registration/point_to_plane_registration.hpp"
#include "voxel_map/voxel_hash_map.hpp"

namespace liloc {

struct LoopClosureConfig {
  // Candidates: earlier keyframes within this distance of the current estimate. The
  // odometry drifts 0.1-0.3 % of the distance driven, so position is the primary cue;
  // 30 m covers that drift over loops of many kilometres and two passes of a street in
  // opposite lanes or across an intersection, whose clouds still overlap.
  double search_radius_m = 30.0;
  // ... and at least this much older: the last 30 s (~200 m) are what the odometry
  // registered against its own map; matching them adds nothing and hides real loops.
  double min_time_gap_s = 30.0;
  // Eq. 4 distance above which a nearby keyframe is not tried. Simulated campus, all four
  // LiDAR models: the same place within 5 m, up to 0.37; places 50 m and more apart,
  // above 0.52 for 99 % of the pairs.
  double max_descriptor_distance = 0.45;
  // At most this many registrations per keyframe, best first: the best match of each
  // earlier pass through the search radius (a run of consecutive nearby keyframes).
  int candidates = 3;
  // Stored clouds (and what is registered) are downsampled to this: memory per keyframe
  // stays a few thousand points, the resolution of the odometry's own registration.
  double verify_voxel_m = 0.5;
  // Keyframes index +- this around the candidate (~+-10 m) form the target map: enough
  // for the current cloud's overlap, short enough for the odometry to be consistent.
  int local_map_half_window = 10;
  // Acceptance, measured on the simulated campus (VLP-16, 0.5 m voxels, candidates up to
  // 15 m away): the same place matches 17-31 % of the points at an RMS of 2.5-3.5 cm
  // (up to 9 cm 15 m away), other places 5-12 % at 6-20 cm and mostly degenerate.
  // Degenerate registrations are refused too: along their weak direction the result is
  // whatever the start was.
  double max_fitness_m = 0.08;         // RMS point-to-plane distance of the matches
  int min_correspondences = 300;       // matches, at least ...
  double min_matched_fraction = 0.15;  // ... and this fraction of the registered points
  // Information: point residuals are correlated (they share planes, and the target map
  // is stitched from odometry poses), so the registration's information, which counts
  // every match as independent, is scaled down to this many independent matches; the
  // target map's own inconsistency (drift over the window, ~0.1-0.3 % of 20 m) is added
  // as a covariance floor.
  int independent_correspondences = 100;
  double map_sigma_translation_m = 0.02;
  double map_sigma_rotation_rad = 0.002;
  // Plausibility: the correction of the odometry's relative pose must stay below
  //   translation: correction_floor_m + max_drift_fraction * distance travelled,
  //   rotation:    correction_floor_rad + max_rotation_drift_rad_per_m * distance travelled,
  // distance travelled being the path from the candidate to the current keyframe. The
  // rates are about ten times the odometry's drift (0.3 % of distance; its heading error
  // grows ~1e-5 rad/m); the floors cover registration error and short paths. A wrong
  // place that passed registration is off by a lane, a block or a turn, far beyond.
  double max_drift_fraction = 0.02;
  double correction_floor_m = 0.5;
  double max_rotation_drift_rad_per_m = 1e-4;
  double correction_floor_rad = 0.035;
  // More iterations and associations than the odometry's: the start is off by the drift
  // of a whole loop, not by one sweep's motion. Planes as loose as 0.25 (the odometry
  // needs 0.4 against the bands its own nearby sweeps leave): the target is a local map
  // of 20 keyframes from several viewpoints, and the acceptance above was measured so.
  RegistrationConfig registration = [] {
    RegistrationConfig c;
    c.max_iterations = 30;
    c.max_associations = 10;
    c.min_planarity = 0.25;
    return c;
  }();
  VoxelMapConfig target_map;  // the local map built around a candidate

  template <class V>
  void visit_fields(V& v) {
    v("search_radius_m", search_radius_m);
    v("min_time_gap_s", min_time_gap_s);
    v("max_descriptor_distance", max_descriptor_distance);
    v("candidates", candidates);
    v("verify_voxel_m", verify_voxel_m);
    v("local_map_half_window", local_map_half_window);
    v("max_fitness_m", max_fitness_m);
    v("min_correspondences", min_correspondences);
    v("min_matched_fraction", min_matched_fraction);
    v("independent_correspondences", independent_correspondences);
    v("map_sigma_translation_m", map_sigma_translation_m);
    v("map_sigma_rotation_rad", map_sigma_rotation_rad);
    v("max_drift_fraction", max_drift_fraction);
    v("correction_floor_m", correction_floor_m);
    v("max_rotation_drift_rad_per_m", max_rotation_drift_rad_per_m);
    v("correction_floor_rad", correction_floor_rad);
    v("registration", registration);
    v("target_map", target_map);
  }
  void validate() const;
};

struct LoopClosure {
  int64_t from_id = 0;  // the older keyframe
  int64_t to_id = 0;    // the newer one
  // Relative pose measured by registration: from-body <- to-body.
  Eigen::Isometry3d T_from_to = Eigen::Isometry3d::Identity();
  // For the pose graph: over the right perturbation of T_from_to (math/se3.hpp).
  Matrix6d information = Matrix6d::Identity();
  double fitness_m = 0.0;  // RMS point-to-plane distance of the matches
  double descriptor_distance = 0.0;
};

struct LoopClosureStats {
  int64_t keyframes = 0;
  int64_t nearby = 0;                    // earlier keyframes within the radius and time gap
  int64_t rejected_descriptor = 0;       // nearby, but beyond max_descriptor_distance
  int64_t tried = 0;                     // candidates registered
  int64_t yaw_refined = 0;               // ... starting from the descriptor's yaw
  int64_t verified = 0;                  // closures returned
  int64_t rejected_correspondences = 0;  // too few matches, or too small a fraction
  int64_t rejected_degenerate = 0;
  int64_t rejected_fitness = 0;
  int64_t rejected_implausible = 0;  // correction too large for the distance travelled
  double descriptor_ms = 0.0;        // total time making and comparing descriptors
  double verification_ms = 0.0;      // total time building target maps and registering
};

class LoopClosureDetector {
 public:
  // `descriptor`: the system's one descriptor (the map's and the initializer's too).
  explicit LoopClosureDetector(const LoopClosureConfig& config,
                               const PolarDescriptorConfig& descriptor = {});

  // Adds the next keyframe (pose as currently estimated by odometry, cloud in its body
  // frame) and returns the verified closures between earlier keyframes (from) and it
  // (to), best descriptor match first. Keyframes must come in time order with distinct
  // ids; throws std::invalid_argument otherwise.
  std::vector<LoopClosure> add(const MapKeyframe& keyframe, const PointCloud& cloud_body);

  const LoopClosureStats& stats() const { return stats_; }
  size_t num_keyframes() const { return keyframes_.size(); }

 private:
  struct Stored {
    int64_t id;
    int64_t utime_us;
    Eigen::Isometry3d T_map_body;
    double path_m;  // odometry path length from the first keyframe
    PolarDescriptor descriptor;
    std::vector<Eigen::Vector3f> points_body;  // downsampled to verify_voxel_m
  };
  struct Candidate {
    size_t index;
    size_t pass;  // number of the earlier pass through the search radius
    DescriptorMatch match;
  };

  std::vector<Candidate> select_candidates(const Stored& query, size_t old_end);
  bool verify(const Stored& query, const Candidate& candidate, size_t old_end,
              LoopClosure& closure);

  LoopClosureConfig config_;
  PolarDescriptorConfig descriptor_;
  std::vector<Stored> keyframes_;  // in time order
  LoopClosureStats stats_;
};

}  // namespace liloc
