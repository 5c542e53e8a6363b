#pragma once
// Keyframe clouds in memory, least recently used first out, bounded by bytes: the map
// server answers submap requests of several robots from threads, and the keyframes of a
// busy area are requested again and again.

#include <cstddef>
#include <cstdint>
#include <future>
#include <list>
#include <memory>
#include <mutex>
#include <unordered_map>

#include "pointcloud/point_cloud.hpp"
#include "storage/map_store.hpp"

namespace liloc::storage {

class CloudCache {
 public:
  // `store` must outlive the cache.
  CloudCache(const MapStore& store, size_t max_bytes);

  // The keyframe's cloud, from memory or from the store (whose MapError propagates; a
  // failed load is not remembered). Thread-safe; concurrent requests for a keyframe that
  // is not in memory load it once. A cloud larger than max_bytes is returned, not kept.
  std::shared_ptr<const PointCloud> get(int64_t keyframe_id);

  size_t bytes() const;  // of the clouds held
  size_t max_bytes() const { return max_bytes_; }
  int64_t hits() const;    // requests answered without a load of their own
  int64_t misses() const;  // loads from the store

  // Memory a cloud is accounted with: its point and intensity arrays.
  static size_t bytes_of(const PointCloud& cloud);

 private:
  using CloudPtr = std::shared_ptr<const PointCloud>;
  struct Entry {
    int64_t keyframe_id;
    CloudPtr cloud;
    size_t bytes;
  };

  void insert_locked(int64_t keyframe_id, const CloudPtr& cloud);

  const MapStore& store_;
  const size_t max_bytes_;
  mutable std::mutex mutex_;
  std::list<Entry> entries_;  // most recently used first
  std::unordered_map<int64_t, std::list<Entry>::iterator> by_id_;
  std::unordered_map<int64_t, std::shared_future<CloudPtr>> loading_;
  size_t bytes_ = 0;
  int64_t hits_ = 0;
  int64_t misses_ = 0;
};

}  // namespace liloc::storage
