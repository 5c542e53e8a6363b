#pragma once
// Pose initialization against a map directory read directly (storage/), not through the
// map server: for liloc_map localize and the initialization bench.

#include <memory>
#include <string>

#include "initializer/map_index.hpp"
#include "initializer/pose_initializer.hpp"
#include "storage/map_store.hpp"

namespace liloc {

// The index of `map` (the store's current version), each keyframe's descriptor read from
// its file. Throws storage::MapError for an unreadable one.
MapIndex load_map_index(const storage::MapStore& store, const MapData& map,
                        const PolarDescriptorConfig& descriptor);

// The points of a submap in the map frame, read from the store's keyframe clouds and
// downsampled to voxel_m, kept once read (the store and map must outlive the source).
SubmapTargets::Source submap_points_from(const storage::MapStore& store, const MapData& map,
                                         double voxel_m);

// A map directory opened for searches: its current version, index and submap points (at
// voxel_m). Throws storage::MapError for a map that cannot be read.
struct OpenedMap {
  OpenedMap(const std::string& directory, const PolarDescriptorConfig& descriptor, double voxel_m);
  OpenedMap(const OpenedMap&) = delete;
  OpenedMap& operator=(const OpenedMap&) = delete;

  storage::MapStore store;
  MapData data;
  MapIndex index;
  SubmapTargets::Source points;  // refers to store and data: the map does not move
};

}  // namespace liloc
