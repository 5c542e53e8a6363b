#pragma once
// A correlative search over (x, y, yaw): every pose of a grid around a coarse pose scored by
// how many of the query's points fall into occupied cells of the map. It needs no
// descriptor and no start within registration's reach, so it finds starts where the map's
// keyframes are metres away and their descriptors' yaw is off (a parallel street, the
// other lane, a changed world); registration then refines the best distinct poses.
//
// Positions step by whole cells, so each yaw's points are put into cells once and a shift is
// an integer offset: a few million hash lookups for a 12 m x 12 m x 70 degree window.
#include <Eigen/Geometry>
#include <vector>

#include "pointcloud/voxel_index_table.hpp"

namespace liloc {

struct CorrelativeSearchConfig {
  double cell_m = 1.0;         // occupancy cell edge, and the grid's position step
  double yaw_step_deg = 2.0;   // the grid's yaw step
  int max_points = 300;        // query points scored: at least this, under twice (see search)
  int peaks = 4;               // best distinct poses returned
  double distinct_m = 2.0;     // peaks at least this far apart ...
  double distinct_deg = 10.0;  // ... or this far apart in yaw
  template <class V>
  void visit_fields(V& v) {
    v("cell_m", cell_m);
    v("yaw_step_deg", yaw_step_deg);
    v("max_points", max_points);
    v("peaks", peaks);
    v("distinct_m", distinct_m);
    v("distinct_deg", distinct_deg);
  }
  void validate() const;
};

// The search window: centre and half-widths.
struct SearchWindow {
  double x_m = 0.0, y_m = 0.0, z_m = 0.0, yaw_rad = 0.0;
  double half_xy_m = 6.0;
  double half_yaw_rad = 0.6;
};

struct ScoredPose {
  Eigen::Isometry3d T_map_body = Eigen::Isometry3d::Identity();
  double score = 0.0;  // fraction of the scored points in occupied cells
};

class CorrelativeSearch {
 public:
  // The map's points (map frame) make the occupancy.
  CorrelativeSearch(const std::vector<Eigen::Vector3f>& map_points,
                    const CorrelativeSearchConfig& config);

  // The best distinct poses in the window, best first. points_body: the query in the body
  // frame; R_level_body its roll and pitch (the poses' rotations are Rz(yaw) R_level_body).
  std::vector<ScoredPose> search(const std::vector<Eigen::Vector3f>& points_body,
                                 const Eigen::Matrix3d& R_level_body,
                                 const SearchWindow& window) const;

 private:
  CorrelativeSearchConfig config_;
  VoxelIndexTable occupied_;
};

}  // namespace liloc
