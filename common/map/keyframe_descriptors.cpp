#include "map/keyframe_descriptors.hpp"

namespace liloc {

std::map<int64_t, std::vector<uint8_t>> encode_keyframe_descriptors(
    const std::vector<MapKeyframe>& keyframes, const std::map<int64_t, PointCloud>& clouds_body,
    const PolarDescriptorConfig& config) {
  std::map<int64_t, std::vector<uint8_t>> out;
  for (const MapKeyframe& kf : keyframes) {
    const auto cloud = clouds_body.find(kf.id);
    if (cloud != clouds_body.end()) {
      out[kf.id] =
          encode(make_level_polar_descriptor(cloud->second, kf.T_map_body.linear(), config));
    }
  }
  return out;
}

}  // namespace liloc
