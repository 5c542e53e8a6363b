#pragma once
// What pose initialization knows of the central session before it looks at any cloud:
// every keyframe's pose, submap and level polar descriptor (Eq. 3, computed when the map
// was built and kept in the map directory, so nothing recomputes them per query), a
// rotation-invariant retrieval key per keyframe for the global search, and Tree_p /
// Tree_m for the coarse one.

#include <cstdint>
#include <map>
#include <memory>
#include <vector>

#include "descriptor/polar_descriptor.hpp"
#include "map/map_types.hpp"
#include "map/submap_database.hpp"

namespace liloc {

// Rotation invariant, so that the global search can rank every keyframe of a map without
// knowing the heading: per ring, the fraction of occupied sectors and the mean height
// above the descriptor's floor, in metres.
std::vector<float> retrieval_key(const PolarDescriptor& descriptor);

class MapIndex {
 public:
  struct Keyframe {
    int64_t id = 0;
    int64_t submap_id = -1;
    Eigen::Isometry3d T_map_body = Eigen::Isometry3d::Identity();
    PolarDescriptor descriptor;
    std::vector<float> key;  // retrieval_key(descriptor)
  };

  // `descriptors`: the encoded descriptor of each keyframe by id (storage's .desc files);
  // keyframes without one are left out of the searches. Throws std::invalid_argument for
  // a descriptor that does not decode or has other dimensions than `config`.
  MapIndex(const MapData& map, const std::map<int64_t, std::vector<uint8_t>>& descriptors,
           const PolarDescriptorConfig& config);
  MapIndex(const MapIndex&) = delete;
  MapIndex& operator=(const MapIndex&) = delete;
  MapIndex(MapIndex&&) = default;
  MapIndex& operator=(MapIndex&&) = default;

  const std::vector<Keyframe>& keyframes() const { return keyframes_; }
  const MapData& map() const { return *map_; }
  const SubmapDatabase& submaps() const { return *database_; }
  int64_t version() const { return map_->version; }

 private:
  // On the heap: the database refers to the map, and both must keep their address when
  // the index moves.
  std::unique_ptr<MapData> map_;
  std::unique_ptr<SubmapDatabase> database_;
  std::vector<Keyframe> keyframes_;
};

}  // namespace liloc
