#include "pointcloud/elevation_gap.hpp"

#include <algorithm>
#include <cmath>

namespace liloc {

std::optional<double> largest_elevation_gap_rad(const std::vector<LidarPoint>& points,
                                                const ElevationGapConfig& config) {
  std::vector<double> elevations;
  for (const LidarPoint& p : points) {
    const Eigen::Vector3d q = p.position_m.cast<double>();
    if (!q.allFinite() || q.norm() < config.min_range_m) {
      continue;
    }
    const double elevation = std::atan2(q.z(), q.head<2>().norm());
    if (elevation >= config.lo_rad && elevation <= config.hi_rad) {
      elevations.push_back(elevation);
    }
  }
  if (static_cast<int>(elevations.size()) < std::max(config.min_points, 2)) {
    return std::nullopt;
  }
  std::sort(elevations.begin(), elevations.end());
  double largest = 0.0;
  for (size_t i = 1; i < elevations.size(); ++i) {
    largest = std::max(largest, elevations[i] - elevations[i - 1]);
  }
  return largest;
}

}  // namespace liloc
