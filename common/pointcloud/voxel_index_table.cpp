#include "pointcloud/voxel_index_table.hpp"

namespace liloc {

VoxelIndexTable::VoxelIndexTable(size_t expected_keys) {
  size_t slots = 16;
  while (slots < 2 * expected_keys) {
    slots *= 2;
  }
  rehash(slots);
}

void VoxelIndexTable::rehash(size_t slots) {
  slots_.assign(slots, kMissing);
  mask_ = slots - 1;
  for (uint32_t i = 0; i < keys_.size(); ++i) {
    uint64_t s = slot_of(keys_[i]);
    while (slots_[s] != kMissing) {
      s = (s + 1) & mask_;
    }
    slots_[s] = i;
  }
}

std::pair<uint32_t, bool> VoxelIndexTable::insert(uint64_t key) {
  uint64_t s = slot_of(key);
  for (;; s = (s + 1) & mask_) {
    const uint32_t i = slots_[s];
    if (i == kMissing) {
      break;
    }
    if (keys_[i] == key) {
      return {i, false};
    }
  }
  const uint32_t index = static_cast<uint32_t>(keys_.size());
  keys_.push_back(key);
  slots_[s] = index;
  if (2 * keys_.size() > slots_.size()) {
    rehash(2 * slots_.size());
  }
  return {index, true};
}

void VoxelIndexTable::assign(std::vector<uint64_t> keys) {
  keys_ = std::move(keys);
  size_t slots = 16;
  while (slots < 2 * keys_.size()) {
    slots *= 2;
  }
  rehash(slots);
}

}  // namespace liloc
