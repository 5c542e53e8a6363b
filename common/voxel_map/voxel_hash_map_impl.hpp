#pragma once
// Template part of voxel_hash_map.hpp.

#include <algorithm>
#include <cmath>

#include "pointcloud/voxel_grid.hpp"

namespace liloc {

template <int K>
Neighbors<K> VoxelHashMap::nearest(const Eigen::Vector3f& q, float max_distance_m) const {
  Neighbors<K> result;
  const float max_sq = max_distance_m * max_distance_m;
  // The 2 x 2 x 2 voxels around q: q's own and, on each axis, the neighbour on the side
  // of q's half of its voxel. They hold every point within voxel_m / 2 of q.
  const Eigen::Vector3f scaled = q * inv_voxel_;
  const Eigen::Vector3i c(static_cast<int>(std::floor(scaled.x())),
                          static_cast<int>(std::floor(scaled.y())),
                          static_cast<int>(std::floor(scaled.z())));
  const Eigen::Vector3i side((scaled.x() - c.x()) < 0.5f ? -1 : 1,
                             (scaled.y() - c.y()) < 0.5f ? -1 : 1,
                             (scaled.z() - c.z()) < 0.5f ? -1 : 1);
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3i index =
        c + Eigen::Vector3i((corner & 1) ? side.x() : 0, (corner & 2) ? side.y() : 0,
                            (corner & 4) ? side.z() : 0);
    const uint32_t found = index_.find(voxel_key(index));
    if (found == VoxelIndexTable::kMissing) {
      continue;
    }
    const Voxel& v = voxels_[found];
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
        result.views[j] = result.views[j - 1];
        --j;
      }
      result.squared_distances[j] = d;
      result.points[j] = v.points[i];
      result.views[j] = v.views[i];
      result.count = std::min(result.count + 1, K);
    }
  }
  return result;
}

}  // namespace liloc
