#pragma once
// Deduplicated submap clouds (map/submap_clouds.hpp) kept next to a map, so that the map
// server answers a submap request by reading one file instead of deduplicating ~20
// keyframe clouds:
//
//   <map>/derived/submap_clouds/000004-<key>.bin
//
// `key` (16 hex digits) is a hash of what the clouds derive from: the voxel size, the
// submap's id, its keyframes' ids and poses. A changed submap has another key, so a stale
// file is never served. These files are not part of a map version (docs/map_format.md):
// they can be deleted at any time and are recomputed; a damaged one (each file ends with
// its CRC-32) is ignored, counted and recomputed, never an error of the map.

#include <atomic>
#include <cstdint>
#include <string>

#include "map/submap_clouds.hpp"

namespace liloc::storage {

class SubmapCloudFiles final : public SubmapCloudStore {
 public:
  // No I/O until a method needs it.
  SubmapCloudFiles(std::string map_directory, double voxel_m);

  double voxel_m() const override { return voxel_m_; }
  bool contains(const Submap& submap, const std::vector<MapKeyframe>& keyframes) const override;
  std::optional<SubmapClouds> load(const Submap& submap,
                                   const std::vector<MapKeyframe>& keyframes) const override;
  // Atomic (a temporary file renamed); throws MapError if it cannot write.
  void save(const Submap& submap, const std::vector<MapKeyframe>& keyframes,
            const SubmapClouds& clouds) const override;

  // Removes the files of submaps `map` no longer has (or has changed), and temporaries.
  // Returns how many files were removed.
  int prune(const MapData& map) const;

  // Files found damaged by load() (truncated, checksum, another submap's).
  int64_t damaged() const { return damaged_.load(); }

  // Relative to the map directory.
  std::string relative_path(const Submap& submap, const std::vector<MapKeyframe>& keyframes) const;

 private:
  std::string directory_;  // <map>/derived/submap_clouds
  std::string map_directory_;
  double voxel_m_;
  mutable std::atomic<int64_t> damaged_{0};
  mutable std::atomic<uint64_t> temporaries_{0};
};

}  // namespace liloc::storage
