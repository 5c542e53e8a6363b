#pragma once
// Maps 64-bit voxel keys (voxel_key()) to dense indices 0, 1, 2 ... in insertion order:
// a flat open-addressing table with linear probing, kept at most half full. Voxel
// structures (downsampling, the odometry's map) are sequences of these lookups, and a
// node-based hash map spends them chasing pointers.

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace liloc {

class VoxelIndexTable {
 public:
  static constexpr uint32_t kMissing = 0xffffffffu;

  explicit VoxelIndexTable(size_t expected_keys = 1024);

  // The key's index, inserting it as index size() if new; .second is true if inserted.
  std::pair<uint32_t, bool> insert(uint64_t key);
  // The key's index, or kMissing.
  uint32_t find(uint64_t key) const {
    for (uint64_t s = slot_of(key);; s = (s + 1) & mask_) {
      const uint32_t i = slots_[s];
      if (i == kMissing || keys_[i] == key) {
        return i;
      }
    }
  }

  // Replaces the contents: key i gets index i.
  void assign(std::vector<uint64_t> keys);

  size_t size() const { return keys_.size(); }
  const std::vector<uint64_t>& keys() const { return keys_; }

 private:
  uint64_t slot_of(uint64_t key) const {
    key ^= key >> 33;
    key *= 0xff51afd7ed558ccdULL;
    key ^= key >> 33;
    return key & mask_;
  }
  void rehash(size_t slots);

  std::vector<uint64_t> keys_;   // by index
  std::vector<uint32_t> slots_;  // slot -> index, kMissing if free
  uint64_t mask_ = 0;
};

}  // namespace liloc
