#pragma once
// The map around a moving robot as registration targets, one voxel map per registration
// stage: submaps are inserted as they come within reach and voxels dropped as they fall
// behind, so that moving on costs one submap's insertion, not a new target of every submap
// around (a new target per change of the submap set cost up to 170 ms a keyframe).

#include <cstdint>
#include <memory>
#include <optional>
#include <set>
#include <vector>

#include "initializer/map_index.hpp"
#include "initializer/pose_initializer.hpp"
#include "voxel_map/voxel_hash_map.hpp"

namespace liloc {

class SlidingTarget {
 public:
  // One voxel map per entry of voxel_m. Submaps within radius_m of the robot are inserted
  // and forgotten beyond radius_m + kHysteresisM; voxels are dropped beyond keep_m, which
  // must exceed that by a submap's reach (its keyframes' extent and the LiDAR's range), so
  // that a submap still inserted never loses points.
  SlidingTarget(std::vector<double> voxel_m, double radius_m, double keep_m);

  // Brings the targets to `position`: inserts the submaps within reach that `targets` has,
  // returns those it does not have (yet).
  std::vector<int64_t> update(const MapIndex& index, const SubmapTargets& targets,
                              const Eigen::Vector3d& position);
  const VoxelHashMap& stage(size_t s) const { return *stages_[s]; }
  size_t submaps() const { return inserted_.size(); }

  static constexpr double kHysteresisM = 10.0;

 private:
  double radius_m_;
  std::optional<Eigen::Vector3d> trimmed_at_;  // where far voxels were last dropped
  std::vector<std::unique_ptr<VoxelHashMap>> stages_;
  std::set<int64_t> inserted_;
};

}  // namespace liloc
