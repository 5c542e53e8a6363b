#include "initializer/map_index.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace liloc {

std::vector<float> retrieval_key(const PolarDescriptor& d) {
  std::vector<float> heights;
  for (size_t k = 0; k < d.occupied.size(); ++k) {
    if (d.occupied[k] != 0) {
      heights.push_back(d.max_height_m[k]);
    }
  }
  float floor = 0.0f;
  if (!heights.empty()) {
    // The 5th percentile, as the descriptor's distance takes it: the ground.
    const size_t k = heights.size() / 20;
    std::nth_element(heights.begin(), heights.begin() + static_cast<ptrdiff_t>(k), heights.end());
    floor = heights[k];
  }
  std::vector<float> key(2 * static_cast<size_t>(d.rings), 0.0f);
  for (int i = 0; i < d.rings; ++i) {
    int occupied = 0;
    float height = 0.0f;
    for (int j = 0; j < d.sectors; ++j) {
      const size_t cell = static_cast<size_t>(i) * d.sectors + j;
      if (d.occupied[cell] != 0) {
        ++occupied;
        height += std::max(0.0f, d.max_height_m[cell] - floor);
      }
    }
    key[2 * i] = static_cast<float>(occupied) / d.sectors;
    key[2 * i + 1] = occupied > 0 ? height / occupied : 0.0f;
  }
  return key;
}

MapIndex::MapIndex(const MapData& map, const std::map<int64_t, std::vector<uint8_t>>& descriptors,
                   const PolarDescriptorConfig& config)
    : map_(std::make_unique<MapData>(map)), database_(std::make_unique<SubmapDatabase>(*map_)) {
  config.validate();
  keyframes_.reserve(map_->keyframes.size());
  for (const MapKeyframe& kf : map_->keyframes) {
    const auto bytes = descriptors.find(kf.id);
    if (bytes == descriptors.end()) {
      continue;
    }
    Keyframe entry;
    entry.id = kf.id;
    entry.submap_id = kf.submap_id;
    entry.T_map_body = kf.T_map_body;
    try {
      entry.descriptor = decode_descriptor(bytes->second.data(), bytes->second.size());
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("keyframe " + std::to_string(kf.id) + ": descriptor " + e.what());
    }
    if (entry.descriptor.rings != config.rings || entry.descriptor.sectors != config.sectors) {
      throw std::invalid_argument("keyframe " + std::to_string(kf.id) + ": descriptor of " +
                                  std::to_string(entry.descriptor.rings) + " x " +
                                  std::to_string(entry.descriptor.sectors) +
                                  " cells, the config says " + std::to_string(config.rings) +
                                  " x " + std::to_string(config.sectors));
    }
    entry.key = retrieval_key(entry.descriptor);
    keyframes_.push_back(std::move(entry));
  }
}

}  // namespace liloc
