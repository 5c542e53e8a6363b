#pragma once
// Builds the central session from one recorded drive: the odometry's keyframes become
// the map's keyframes, consecutive ones linked by odometry edges; loop closures
// (descriptor candidates verified by registration) add loop edges; the pose graph is
// optimized, levelled by the odometry's gravity where it ran with an IMU; the keyframes
// are joined into submaps (Eq. 2). The paper builds its prior map from odometry alone;
// closing loops makes a 1.5 km drive a consistent map.
// The submap rule (Eq. 2) and the descriptor are the system's (one source each, shared
// with the map service and the initializer), not the builder's.

#include <map>
#include <string>
#include <vector>

#include "loop_closure/loop_closure.hpp"
#include "map/map_types.hpp"
#include "map/submap_database.hpp"
#include "mapping/pose_graph_optimizer.hpp"
#include "odometry/odometry_types.hpp"

namespace liloc {

struct CentralSessionConfig {
  std::string session = "A";
  // Odometry edges: what one keyframe-to-keyframe odometry step is trusted to (1 sigma),
  // plus a fraction of the distance travelled.
  double odometry_translation_sigma_m = 0.01;
  double odometry_rotation_sigma_rad = 0.002;
  double odometry_drift_fraction = 0.005;
  bool close_loops = true;
  LoopClosureConfig loops;
  PoseGraphConfig graph;

  template <class V>
  void visit_fields(V& v) {
    v("session", session);
    v("odometry_translation_sigma_m", odometry_translation_sigma_m);
    v("odometry_rotation_sigma_rad", odometry_rotation_sigma_rad);
    v("odometry_drift_fraction", odometry_drift_fraction);
    v("close_loops", close_loops);
    v("loops", loops);
    v("graph", graph);
  }
  void validate() const;
};

struct CentralSessionReport {
  size_t keyframes = 0;
  size_t loop_closures = 0;
  PoseGraphResult graph;
  size_t submaps = 0;
};

class CentralSessionBuilder {
 public:
  CentralSessionBuilder(const CentralSessionConfig& config, const SubmapConfig& submaps,
                        const PolarDescriptorConfig& descriptor);

  // The drive's next keyframe (its odometry frame becomes the map frame).
  void add(const Keyframe& keyframe);

  // Optimizes and cuts into submaps. The clouds (body frame) are moved into *clouds.
  MapData build(std::map<int64_t, PointCloud>* clouds, CentralSessionReport* report);

 private:
  CentralSessionConfig config_;
  SubmapConfig submaps_;
  LoopClosureDetector loops_;
  std::vector<MapKeyframe> keyframes_;
  std::vector<PoseGraphEdge> edges_;
  std::vector<GravityObservation> gravity_;
  std::map<int64_t, PointCloud> clouds_;
  size_t loop_closures_ = 0;
};

}  // namespace liloc
