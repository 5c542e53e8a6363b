#pragma once
// Template part of voxel_hash_map.hpp.

#include <algorithm>

#include "pointcloud/voxel_grid.hpp"

namespace liloc {

template <int K>
Neighbors<K> VoxelHashMap::nearest(const Eigen::Vector3f& q, float max_distance_m) const {
  Neighbors<K> result;
  const float max_sq = max_distance_m * max_distance_m;
  const Eigen::Vector3i c = index_of(q);
  for (int dz = -1; dz <= 1; ++dz) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const auto it = voxels_.find(voxel_key(c + Eigen::Vector3i(dx, dy, dz)));
        if (it == voxels_.end()) {
          continue;
        }
        const Voxel& v = it->second;
        for (int i = 0; i < v.count; ++i) {
          const float d = (v.points[i] - q).squaredNorm();
          if (d > max_sq || (result.count == K && d >= result.squared_distances[K - 1])) {
            continue;
          }
          // Insertion into the sorted list of the best K.
          int j = std::min(result.count, K - 1);
          while (j > 0 && result.squared_distances[j - 1] > d) {
            result.squared_distances[j] = result.squared_distances[j - 1];
            result.points[j] = result.points[j - 1];
            --j;
          }
          result.squared_distances[j] = d;
          result.points[j] = v.points[i];
          result.count = std::min(result.count + 1, K);
        }
      }
    }
  }
  return result;
}

}  // namespace liloc
