#include "optimizer_node/map_growth.hpp"

#include <algorithm>
#include <stdexcept>

namespace liloc {

void MapGrowthConfig::validate() const {
  if (update_keyframes < 1 || max_chunk_points < 1000) {
    throw std::invalid_argument(
        "map growth: update_keyframes must be at least 1, max_chunk_points at least 1000");
  }
}

MapGrowth::MapGrowth(const MapGrowthConfig& config, std::string robot_id)
    : config_(config), robot_id_(std::move(robot_id)) {
  config_.validate();
}

void MapGrowth::add(const LocalizerKeyframe& keyframe, const Eigen::Isometry3d& T_map_body) {
  Kept& k = keyframes_[keyframe.id];
  k.keyframe.sender_keyframe_id = keyframe.id;
  k.keyframe.utime_us = keyframe.utime_us;
  k.keyframe.T_map_body = T_map_body;
  k.keyframe.fitness_m = keyframe.odometry_fitness_m;
  k.keyframe.cloud_body = keyframe.cloud_body;
}

void MapGrowth::finalize(const std::vector<KeyframePose>& finalized) {
  for (const KeyframePose& pose : finalized) {
    const auto it = keyframes_.find(pose.keyframe_id);
    if (it != keyframes_.end()) {
      it->second.keyframe.T_map_body = pose.T_map_body;
      it->second.final = true;
    }
  }
}

std::vector<MapUpdatePart> MapGrowth::take_update(const std::string& session_id,
                                                  int64_t base_map_version, bool flush) {
  const size_t final = static_cast<size_t>(std::count_if(
      keyframes_.begin(), keyframes_.end(), [](const auto& k) { return k.second.final; }));
  const bool due = flush ? !keyframes_.empty()
                         : final >= static_cast<size_t>(config_.update_keyframes) ||
                               (final > 0 && final == keyframes_.size());
  if (!config_.enabled || !due) {
    return {};
  }
  std::vector<MapUpdatePart> parts;
  size_t points = 0;
  for (auto it = keyframes_.begin(); it != keyframes_.end();) {
    if (!flush && !it->second.final) {
      ++it;
      continue;
    }
    const size_t size = it->second.keyframe.cloud_body.size();
    if (parts.empty() ||
        (points > 0 && points + size > static_cast<size_t>(config_.max_chunk_points))) {
      parts.emplace_back();
      points = 0;
    }
    parts.back().keyframes.push_back(std::move(it->second.keyframe));
    points += size;
    ++keyframes_sent_;
    it = keyframes_.erase(it);
  }
  const int64_t update_id = next_update_id_++;
  for (size_t i = 0; i < parts.size(); ++i) {
    parts[i].robot_id = robot_id_;
    parts[i].session_id = session_id;
    parts[i].update_id = update_id;
    parts[i].chunk_index = static_cast<int>(i);
    parts[i].num_chunks = static_cast<int>(parts.size());
    parts[i].base_map_version = base_map_version;
  }
  return parts;
}

size_t MapGrowth::discard() {
  const size_t n = keyframes_.size();
  keyframes_.clear();
  return n;
}

}  // namespace liloc
