#pragma once
// How finely a LiDAR samples elevation near its horizon, measured from one scan.

#include <optional>
#include <vector>

#include "pointcloud/point_cloud.hpp"

namespace liloc {

// The largest elevation step (rad) between the scan's rays in [lo_rad, hi_rad] of its own
// frame, from points at least min_range_m away (closer, a beam's offset from the sensor's
// origin shifts its apparent elevation). A spinning LiDAR's rings sit at fixed elevations,
// so this is its ring spacing there (VLP-16 2 degrees, HDL-32E 1.33, OS1-64 0.53); a
// non-repetitive pattern (Livox Mid-360) fills the band within hundredths of a degree.
// A missing ring (nothing returned, blocked) widens the step, never narrows it. nullopt
// with fewer than min_points such points: the scan does not tell.
struct ElevationGapConfig {
  double lo_rad = -0.14;  // -8 deg: below, the road is seen steeply enough
  double hi_rad = 0.0;
  double min_range_m = 5.0;
  int min_points = 100;
};

std::optional<double> largest_elevation_gap_rad(const std::vector<LidarPoint>& points,
                                                const ElevationGapConfig& config = {});

}  // namespace liloc
