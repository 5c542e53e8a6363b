#pragma once
// The map around a moving robot as registration targets, one voxel map per registration
// stage: submaps are inserted as they come within reach and voxels dropped as they fall
// behind, so that moving on costs one submap's insertion, not a new target of every submap
// around (a new target per change of the submap set cost up to 170 ms a keyframe). Submaps
// a little beyond reach are inserted ahead, after a keyframe's pose is out, so that a
// keyframe does not pay for whole submaps as they come within reach (an OS1-64 submap of
// ~100 000 points took 15-40 ms: the keyframe-to-POSE p99 was 77-85 ms).

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
  // and forgotten beyond radius_m + prefetch_m + kHysteresisM; voxels are dropped beyond
  // keep_m, which must exceed that by a submap's reach (its keyframes' extent and the
  // LiDAR's range), so that a submap still inserted never loses points.
  SlidingTarget(std::vector<double> voxel_m, double radius_m, double prefetch_m, double keep_m);

  struct Update {
    std::vector<int64_t> missing;   // within reach, not in `targets`: registration must wait
    std::vector<int64_t> upcoming;  // within the prefetch ring, not in `targets`: fetch them
  };
  // What a registration at `position` needs now: inserts the submaps within reach that
  // `targets` has; names the ones it does not have (yet) and those just beyond reach.
  Update update(const MapIndex& index, const SubmapTargets& targets,
                const Eigen::Vector3d& position);
  // What can wait until the registration's result is out: the submaps within reach and the
  // nearest one up to prefetch_m beyond that `targets` has go in, so that update() rarely
  // pays for one; submaps and voxels far behind are dropped.
  void prefetch(const MapIndex& index, const SubmapTargets& targets,
                const Eigen::Vector3d& position);
  const VoxelHashMap& stage(size_t s) const { return *stages_[s]; }
  size_t submaps() const { return inserted_.size(); }

  static constexpr double kHysteresisM = 10.0;

 private:
  void insert(const std::vector<Eigen::Vector3f>& points);

  double radius_m_;
  double prefetch_m_;
  std::optional<Eigen::Vector3d> trimmed_at_;  // where far voxels were last dropped
  std::vector<std::unique_ptr<VoxelHashMap>> stages_;
  std::set<int64_t> inserted_;
};

}  // namespace liloc
