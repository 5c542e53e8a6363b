#include "optimizer/sliding_target.hpp"

namespace liloc {

SlidingTarget::SlidingTarget(std::vector<double> voxel_m, double radius_m, double keep_m)
    : radius_m_(radius_m) {
  for (const double v : voxel_m) {
    VoxelMapConfig config;
    config.voxel_m = v;
    config.min_point_spacing_m = v / 5.0;
    config.keep_radius_m = keep_m;
    stages_.push_back(std::make_unique<VoxelHashMap>(config));
  }
}

std::vector<int64_t> SlidingTarget::update(const MapIndex& index, const SubmapTargets& targets,
                                           const Eigen::Vector3d& position) {
  // Submaps whose centroids fell behind are forgotten (their voxels go when they are beyond
  // keep_m), so that they are inserted again if the robot comes back.
  const double forget_m = radius_m_ + kHysteresisM;
  for (auto it = inserted_.begin(); it != inserted_.end();) {
    const Submap* submap = index.submaps().submap(*it);
    if (submap == nullptr || (submap->centroid - position).head<2>().norm() > forget_m) {
      it = inserted_.erase(it);
    } else {
      ++it;
    }
  }
  // Dropping far voxels visits them all: only every kHysteresisM of travel.
  if (!trimmed_at_ || (*trimmed_at_ - position).norm() > kHysteresisM) {
    for (const std::unique_ptr<VoxelHashMap>& stage : stages_) {
      stage->remove_far(position);
    }
    trimmed_at_ = position;
  }
  std::vector<int64_t> missing;
  for (const int64_t id : SubmapTargets::submaps_around(index, position, radius_m_)) {
    if (inserted_.count(id) != 0) {
      continue;
    }
    const std::shared_ptr<const std::vector<Eigen::Vector3f>> points = targets.points(id);
    if (!points) {
      missing.push_back(id);
      continue;
    }
    for (const std::unique_ptr<VoxelHashMap>& stage : stages_) {
      stage->insert(*points);
    }
    inserted_.insert(id);
  }
  return missing;
}

}  // namespace liloc
