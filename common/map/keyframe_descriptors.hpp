#pragma once
// The descriptors stored with a map's keyframes: the level polar descriptor (paper
// Eq. 3) of each keyframe's cloud, levelled with its map pose, encoded for storage.

#include <cstdint>
#include <map>
#include <vector>

#include "descriptor/polar_descriptor.hpp"
#include "map/map_types.hpp"

namespace liloc {

// For every keyframe that has a cloud in `clouds_body`, by keyframe id.
std::map<int64_t, std::vector<uint8_t>> encode_keyframe_descriptors(
    const std::vector<MapKeyframe>& keyframes, const std::map<int64_t, PointCloud>& clouds_body,
    const PolarDescriptorConfig& config);

}  // namespace liloc
