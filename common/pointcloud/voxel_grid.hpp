#pragma once
// Voxel-grid downsampling: one point per occupied voxel.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "pointcloud/point_cloud.hpp"

namespace liloc {

// Integer coordinates of the voxel holding p, for voxels of edge voxel_m.
Eigen::Vector3i voxel_index(const Eigen::Vector3f& p, float voxel_m);

// Packs a voxel index (each coordinate within +-2^20) into one hashable key.
uint64_t voxel_key(const Eigen::Vector3i& index);

// Replaces the points of each voxel by their centroid (and mean intensity). The output
// keeps the order in which voxels were first hit, so it is deterministic.
// voxel_m <= 0 returns the input unchanged.
PointCloud voxel_downsample(const PointCloud& cloud, float voxel_m);

// At most max_points of `points`, evenly spaced over the whole list: beyond a few thousand
// well-spread points, more only cost registration time. Any element type, so that what goes
// with each point (its time) is chosen as the point is.
template <class T>
std::vector<T> evenly_spaced(const std::vector<T>& points, size_t max_points) {
  if (points.size() <= max_points) {
    return points;
  }
  std::vector<T> out;
  out.reserve(max_points);
  const double stride = static_cast<double>(points.size()) / static_cast<double>(max_points);
  for (size_t i = 0; i < max_points; ++i) {
    out.push_back(points[static_cast<size_t>(static_cast<double>(i) * stride)]);
  }
  return out;
}

// The points of voxel_downsample, then evenly_spaced: a registration source of bounded cost.
std::vector<Eigen::Vector3f> sparse_points(const PointCloud& cloud, float voxel_m,
                                           size_t max_points);

}  // namespace liloc
