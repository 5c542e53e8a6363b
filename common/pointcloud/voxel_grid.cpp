#include "pointcloud/voxel_grid.hpp"

#include <algorithm>
#include <cmath>

#include "pointcloud/voxel_index_table.hpp"

namespace liloc {

Eigen::Vector3i voxel_index(const Eigen::Vector3f& p, float voxel_m) {
  return Eigen::Vector3i(static_cast<int>(std::floor(p.x() / voxel_m)),
                         static_cast<int>(std::floor(p.y() / voxel_m)),
                         static_cast<int>(std::floor(p.z() / voxel_m)));
}

uint64_t voxel_key(const Eigen::Vector3i& index) {
  constexpr uint64_t kMask = (uint64_t{1} << 21) - 1;
  constexpr int kOffset = 1 << 20;
  return ((static_cast<uint64_t>(index.x() + kOffset) & kMask) << 42) |
         ((static_cast<uint64_t>(index.y() + kOffset) & kMask) << 21) |
         (static_cast<uint64_t>(index.z() + kOffset) & kMask);
}

PointCloud voxel_downsample(const PointCloud& cloud, float voxel_m) {
  if (voxel_m <= 0.0f) {
    return cloud;
  }
  struct Accumulator {
    Eigen::Vector3f sum = Eigen::Vector3f::Zero();
    float intensity_sum = 0.0f;
    int count = 0;
  };
  VoxelIndexTable voxels(cloud.size() / 4 + 1);
  std::vector<Accumulator> slots;
  slots.reserve(cloud.size() / 4 + 1);
  for (size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f& p = cloud.points[i];
    const auto [index, inserted] = voxels.insert(voxel_key(voxel_index(p, voxel_m)));
    if (inserted) {
      slots.emplace_back();
    }
    Accumulator& acc = slots[index];
    acc.sum += p;
    acc.intensity_sum += cloud.intensities[i];
    ++acc.count;
  }
  PointCloud out;
  out.reserve(slots.size());
  for (const Accumulator& acc : slots) {
    const float inv = 1.0f / static_cast<float>(acc.count);
    out.push_back(acc.sum * inv, acc.intensity_sum * inv);
  }
  return out;
}

std::vector<Eigen::Vector3f> sparse_points(const PointCloud& cloud, float voxel_m,
                                           size_t max_points) {
  return evenly_spaced(voxel_downsample(cloud, voxel_m).points, max_points);
}

}  // namespace liloc
