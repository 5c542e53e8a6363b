#include "optimizer/sliding_target.hpp"

#include <algorithm>
#include <limits>

namespace liloc {

SlidingTarget::SlidingTarget(std::vector<double> voxel_m, double radius_m, double prefetch_m,
                             size_t prefetch_points, double keep_m)
    : radius_m_(radius_m), prefetch_m_(prefetch_m), prefetch_points_(prefetch_points) {
  for (const double v : voxel_m) {
    VoxelMapConfig config;
    config.voxel_m = v;
    config.min_point_spacing_m = v / 5.0;
    config.keep_radius_m = keep_m;
    stages_.push_back(std::make_unique<VoxelHashMap>(config));
  }
}

void SlidingTarget::insert(const std::vector<Eigen::Vector3f>& points, size_t from, size_t to) {
  for (const std::unique_ptr<VoxelHashMap>& stage : stages_) {
    stage->insert(points.data() + from, to - from);
  }
}

SlidingTarget::Update SlidingTarget::update(const MapIndex& index, const SubmapTargets& targets,
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
  if (pending_ && distance_m(pending_->id) > forget_m) {
    pending_.reset();
  }
  // Dropping far voxels visits them all: only every kHysteresisM of travel.
  if (!trimmed_at_ || (*trimmed_at_ - position).norm() > kHysteresisM) {
    for (const std::unique_ptr<VoxelHashMap>& stage : stages_) {
      stage->remove_far(position);
    }
    trimmed_at_ = position;
  }
  Update out;
  // Within reach: all of it now (the rest of one being inserted ahead).
  for (const int64_t id : SubmapTargets::submaps_around(index, position, radius_m_)) {
    if (inserted_.count(id) != 0) {
      continue;
    }
    if (pending_ && pending_->id == id) {
      insert(*pending_->points, pending_->inserted, pending_->points->size());
      pending_.reset();
    } else if (const auto points = targets.points(id)) {
      insert(*points, 0, points->size());
    } else {
      out.missing.push_back(id);
      continue;
    }
    inserted_.insert(id);
  }
  // Ahead: the nearest submap beyond reach, prefetch_points_ of it per update.
  std::vector<KdTree::Hit> ahead =
      index.submaps().submaps_within(position, radius_m_ + prefetch_m_);
  std::sort(ahead.begin(), ahead.end(),
            [](const KdTree::Hit& a, const KdTree::Hit& b) { return a.distance < b.distance; });
  for (const KdTree::Hit& hit : ahead) {
    if (inserted_.count(hit.id) != 0 || (pending_ && pending_->id == hit.id)) {
      continue;
    }
    if (const auto points = targets.points(hit.id)) {
      if (!pending_) {
        pending_ = Pending{hit.id, points, 0};
      }
    } else {
      out.upcoming.push_back(hit.id);
    }
  }
  if (pending_) {
    const size_t to = std::min(pending_->points->size(), pending_->inserted + prefetch_points_);
    insert(*pending_->points, pending_->inserted, to);
    pending_->inserted = to;
    if (to == pending_->points->size()) {
      inserted_.insert(pending_->id);
      pending_.reset();
    }
  }
  return out;
}

}  // namespace liloc
