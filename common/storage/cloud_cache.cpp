#include "storage/cloud_cache.hpp"

namespace liloc::storage {

CloudCache::CloudCache(const MapStore& store, size_t max_bytes)
    : store_(store), max_bytes_(max_bytes) {}

size_t CloudCache::bytes_of(const PointCloud& cloud) {
  return cloud.points.size() * sizeof(Eigen::Vector3f) + cloud.intensities.size() * sizeof(float);
}

std::shared_ptr<const PointCloud> CloudCache::get(int64_t keyframe_id) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (const auto it = by_id_.find(keyframe_id); it != by_id_.end()) {
    ++hits_;
    entries_.splice(entries_.begin(), entries_, it->second);
    return it->second->cloud;
  }
  if (const auto it = loading_.find(keyframe_id); it != loading_.end()) {
    ++hits_;
    const std::shared_future<CloudPtr> pending = it->second;
    lock.unlock();
    return pending.get();
  }
  ++misses_;
  std::promise<CloudPtr> promise;
  loading_.emplace(keyframe_id, promise.get_future().share());
  lock.unlock();

  // Loaded without the lock: other keyframes are served meanwhile.
  CloudPtr cloud;
  try {
    cloud = std::make_shared<const PointCloud>(store_.load_cloud(keyframe_id));
  } catch (...) {
    lock.lock();
    loading_.erase(keyframe_id);
    lock.unlock();
    promise.set_exception(std::current_exception());
    throw;
  }
  lock.lock();
  loading_.erase(keyframe_id);
  insert_locked(keyframe_id, cloud);
  lock.unlock();
  promise.set_value(cloud);
  return cloud;
}

void CloudCache::insert_locked(int64_t keyframe_id, const CloudPtr& cloud) {
  const size_t cloud_bytes = bytes_of(*cloud);
  if (cloud_bytes > max_bytes_) {
    return;
  }
  entries_.push_front({keyframe_id, cloud, cloud_bytes});
  by_id_[keyframe_id] = entries_.begin();
  bytes_ += cloud_bytes;
  while (bytes_ > max_bytes_) {
    const Entry& oldest = entries_.back();
    bytes_ -= oldest.bytes;
    by_id_.erase(oldest.keyframe_id);
    entries_.pop_back();
  }
}

size_t CloudCache::bytes() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return bytes_;
}

int64_t CloudCache::hits() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return hits_;
}

int64_t CloudCache::misses() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return misses_;
}

}  // namespace liloc::storage
