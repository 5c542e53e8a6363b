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
// well-spread points, more only cost registration time.
std::vector<Eigen::Vector3f> evenly_spaced(const std::vector<Eigen::Vector3f>& points,
                                           size_t max_points);

// The points of voxel_downsample, then evenly_spaced: a registration source of bounded cost.
std::vector<Eigen::Vector3f> sparse_points(const PointCloud& cloud, float voxel_m,
                                           size_t max_points);

}  // namespace liloc
