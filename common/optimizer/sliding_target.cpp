#include "optimizer/sliding_target.hpp"

#include <algorithm>
#include <limits>

namespace liloc {

SlidingTarget::SlidingTarget(std::vector<double> voxel_m, double radius_m, double prefetch_m,
                             double keep_m)
    : radius_m_(radius_m), prefetch_m_(prefetch_m) {
  for (const double v : voxel_m) {
    VoxelMapConfig config;
    config.voxel_m = v;
    config.min_point_spacing_m = v / 5.0;
    config.keep_radius_m = keep_m;
    stages_.push_back(std::make_unique<VoxelHashMap>(config));
  }
}

void SlidingTarget::insert(const std::vector<Eigen::Vector3f>& points) {
  for (const std::unique_ptr<VoxelHashMap>& stage : stages_) {
    stage->insert(points);
  }
}

SlidingTarget::Update SlidingTarget::update(const MapIndex& index, const SubmapTargets& targets,
                                            const Eigen::Vector3d& position) {
  Update out;
  for (const int64_t id : SubmapTargets::submaps_around(index, position, radius_m_)) {
    if (inserted_.count(id) != 0) {
      continue;
    }
    if (const auto points = targets.points(id)) {
      insert(*points);
      inserted_.insert(id);
    } else {
      out.missing.push_back(id);
    }
  }
  for (const KdTree::Hit& hit : index.submaps().submaps_within(position, radius_m_ + prefetch_m_)) {
    if (inserted_.count(hit.id) == 0 && !targets.points(hit.id) &&
        std::find(out.missing.begin(), out.missing.end(), hit.id) == out.missing.end()) {
      out.upcoming.push_back(hit.id);
    }
  }
  return out;
}

void SlidingTarget::prefetch(const MapIndex& index, const SubmapTargets& targets,
                             const Eigen::Vector3d& position) {
  const auto distance_m = [&](int64_t id) {
    const Submap* submap = index.submaps().submap(id);
    return submap == nullptr ? std::numeric_limits<double>::infinity()
                             : (submap->centroid - position).head<2>().norm();
  };
  // Submaps whose centroids fell behind are forgotten (their voxels go when they are beyond
  // keep_m), so that they are inserted again if the robot comes back.
  const double forget_m = radius_m_ + prefetch_m_ + kHysteresisM;
  for (auto it = inserted_.begin(); it != inserted_.end();) {
    it = distance_m(*it) > forget_m ? inserted_.erase(it) : std::next(it);
  }
  // Dropping far voxels visits them all: only every kHysteresisM of travel.
  if (!trimmed_at_ || (*trimmed_at_ - position).norm() > kHysteresisM) {
    for (const std::unique_ptr<VoxelHashMap>& stage : stages_) {
      stage->remove_far(position);
    }
    trimmed_at_ = position;
  }
  // Nearest first (KdTree::within's order): those within reach (a start: the next keyframe needs
  // them all), then the nearest one beyond: keyframes come far oftener than submaps come within
  // reach.
  for (const KdTree::Hit& hit : index.submaps().submaps_within(position, radius_m_ + prefetch_m_)) {
    if (inserted_.count(hit.id) != 0) {
      continue;
    }
    if (const auto points = targets.points(hit.id)) {
      insert(*points);
      inserted_.insert(hit.id);
      if (hit.distance > radius_m_) {
        return;
      }
    }
  }
}

}  // namespace liloc
