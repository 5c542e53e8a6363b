#pragma once
// A central session from one point-cloud map (a survey, another mapping system's output):
// pseudo-keyframes on an xy grid, each holding the map's points within a radius of its
// cell, in serpentine order so that consecutive keyframes are neighbours and Eq. 2 joins
// them into compact submaps. Robots then localize against a map liloc did not record.

#include <vector>

#include "odometry/odometry_types.hpp"
#include "pointcloud/point_cloud.hpp"

namespace liloc {

struct PcdTilingConfig {
  double cell_m = 20.0;    // grid spacing of the pseudo-keyframes
  double radius_m = 30.0;  // points within this xy distance of a cell's centre go to it
  double height_m = 1.8;   // a keyframe's height above its cell's ground
  int min_points = 200;    // cells with fewer points get no keyframe
  void validate() const;
};

// The pseudo-keyframes of `map_cloud` (map frame): ids and times count up from 0, the pose
// is the cell's centre at height_m above its ground (a low percentile of its heights), the
// cloud is in that keyframe's frame. Empty if no cell has min_points points.
std::vector<Keyframe> tile_point_cloud(const PointCloud& map_cloud, const PcdTilingConfig& config);

}  // namespace liloc
