#include "map/map_service.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace liloc {

void MapServiceConfig::validate() const {
  submaps.validate();
  if (max_submaps_per_reply < 1 || max_chunk_points < 1 || max_update_keyframes < 1 ||
      max_update_points < 1 || update_timeout_s <= 0) {
    throw std::invalid_argument("limits and timeout must be positive");
  }
}

MapService::MapService(MapData map, CloudSource clouds, const MapServiceConfig& config)
    : map_(std::move(map)), cloud_source_(std::move(clouds)), config_(config), database_(map_) {
  config_.validate();
}

std::shared_ptr<const PointCloud> MapService::cloud(int64_t keyframe_id) {
  const auto merged = merged_clouds_.find(keyframe_id);
  return merged != merged_clouds_.end() ? merged->second : cloud_source_(keyframe_id);
}

std::vector<SubmapReplyPart> MapService::answer(const SubmapQuery& query) {
  ++counters_.requests;
  const size_t limit = static_cast<size_t>(
      query.max_submaps > 0 ? std::min(query.max_submaps, config_.max_submaps_per_reply)
                            : config_.max_submaps_per_reply);
  std::vector<int64_t> ids;
  if (query.by_id) {
    for (const int64_t id : query.submap_ids) {
      if (database_.submap(id) != nullptr && ids.size() < limit) {
        ids.push_back(id);
      }
    }
  } else if (query.position.allFinite()) {
    const std::vector<KdTree::Hit> hits =
        query.radius_m > 0.0 ? database_.submaps_within(query.position, query.radius_m)
                             : database_.nearest_submaps(query.position, 1);
    for (const KdTree::Hit& h : hits) {
      if (ids.size() < limit) {
        ids.push_back(h.id);
      }
    }
  }
  return reply_for(query, ids);
}

std::vector<SubmapReplyPart> MapService::reply_for(const SubmapQuery& query,
                                                   const std::vector<int64_t>& ids) {
  std::vector<SubmapReplyPart> parts;
  const auto base = [&]() {
    SubmapReplyPart p;
    p.robot_id = query.robot_id;
    p.request_id = query.request_id;
    p.map_version = map_.version;
    return p;
  };
  if (ids.empty()) {
    ++counters_.empty_replies;
    SubmapReplyPart p = base();
    p.reply_count = 1;
    parts.push_back(std::move(p));
    return parts;
  }
  for (const int64_t id : ids) {
    const Submap& submap = *database_.submap(id);
    // Chunks of whole keyframes, each under max_chunk_points.
    std::vector<SubmapReplyPart> chunks;
    SubmapReplyPart chunk = base();
    chunk.submap = submap;
    int64_t points = 0;
    for (const int64_t kf_id : submap.keyframe_ids) {
      const MapKeyframe* kf = database_.keyframe(kf_id);
      std::shared_ptr<const PointCloud> c;
      if (query.include_clouds) {
        c = cloud(kf_id);
        if (!chunk.keyframes.empty() &&
            points + static_cast<int64_t>(c->size()) > config_.max_chunk_points) {
          chunks.push_back(std::move(chunk));
          chunk = base();
          chunk.submap = submap;
          points = 0;
        }
        points += static_cast<int64_t>(c->size());
        chunk.clouds.push_back(std::move(c));
      }
      chunk.keyframes.push_back(*kf);
    }
    chunks.push_back(std::move(chunk));
    for (size_t i = 0; i < chunks.size(); ++i) {
      chunks[i].chunk_index = static_cast<int>(i);
      chunks[i].num_chunks = static_cast<int>(chunks.size());
      parts.push_back(std::move(chunks[i]));
    }
  }
  for (size_t i = 0; i < parts.size(); ++i) {
    parts[i].reply_index = static_cast<int>(i);
    parts[i].reply_count = static_cast<int>(parts.size());
  }
  return parts;
}

std::optional<std::string> MapService::validate(const MapUpdatePart& part) const {
  if (!config_.allowed_robots.empty() &&
      std::find(config_.allowed_robots.begin(), config_.allowed_robots.end(), part.robot_id) ==
          config_.allowed_robots.end()) {
    return "robot '" + part.robot_id + "' may not update the map";
  }
  if (part.num_chunks < 1 || part.chunk_index < 0 || part.chunk_index >= part.num_chunks) {
    return "chunk " + std::to_string(part.chunk_index) + " of " + std::to_string(part.num_chunks);
  }
  if (static_cast<int>(part.keyframes.size()) > config_.max_update_keyframes) {
    return std::to_string(part.keyframes.size()) + " keyframes in one part, more than " +
           std::to_string(config_.max_update_keyframes);
  }
  for (const UpdateKeyframe& kf : part.keyframes) {
    if (!kf.T_map_body.matrix().allFinite()) {
      return "keyframe " + std::to_string(kf.sender_keyframe_id) + " has a non-finite pose";
    }
  }
  return std::nullopt;
}

UpdateOutcome MapService::receive(MapUpdatePart part, int64_t now_us) {
  UpdateOutcome outcome;
  const std::pair<std::string, int64_t> key(part.robot_id, part.update_id);
  if (finished_.count(key) != 0) {
    return outcome;  // a repeat of a finished update: nothing to do
  }
  const auto reject = [&](const std::string& reason) {
    pending_.erase(key);
    finished_.insert(key);
    ++counters_.updates_rejected;
    outcome.status = UpdateOutcome::Status::kRejected;
    outcome.reason = reason;
    return outcome;
  };
  if (const std::optional<std::string> problem = validate(part)) {
    return reject(*problem);
  }
  PendingUpdate& update = pending_[key];
  if (update.chunks.empty()) {
    update.session_id = part.session_id;
    update.num_chunks = part.num_chunks;
    update.first_seen_us = now_us;
  } else if (update.num_chunks != part.num_chunks) {
    return reject("parts disagree on the number of chunks");
  }
  for (const UpdateKeyframe& kf : part.keyframes) {
    update.points += static_cast<int64_t>(kf.cloud_body.size());
  }
  if (update.points > config_.max_update_points) {
    return reject(std::to_string(update.points) + " points, more than " +
                  std::to_string(config_.max_update_points));
  }
  update.chunks[part.chunk_index] = std::move(part.keyframes);
  if (static_cast<int>(update.chunks.size()) < update.num_chunks) {
    return outcome;
  }
  outcome = merge(key.first, update);
  pending_.erase(key);
  finished_.insert(key);
  return outcome;
}

void MapService::expire(int64_t now_us) {
  const int64_t timeout_us = static_cast<int64_t>(config_.update_timeout_s * 1e6);
  for (auto it = pending_.begin(); it != pending_.end();) {
    if (now_us - it->second.first_seen_us > timeout_us) {
      ++counters_.updates_expired;
      it = pending_.erase(it);
    } else {
      ++it;
    }
  }
}

UpdateOutcome MapService::merge(const std::string& robot_id, PendingUpdate& update) {
  UpdateOutcome outcome;
  int64_t next_keyframe_id = map_.keyframes.empty() ? 0 : map_.keyframes.back().id + 1;
  int64_t next_submap_id = map_.submaps.empty() ? 0 : map_.submaps.back().id + 1;
  std::vector<MapKeyframe> added;
  for (auto& [index, keyframes] : update.chunks) {
    for (UpdateKeyframe& kf : keyframes) {
      MapKeyframe m;
      m.id = next_keyframe_id++;
      m.utime_us = kf.utime_us;
      m.session = update.session_id.empty() ? robot_id : update.session_id;
      m.T_map_body = kf.T_map_body;
      m.fitness_m = kf.fitness_m;
      added.push_back(m);
      auto cloud = std::make_shared<const PointCloud>(std::move(kf.cloud_body));
      unsaved_clouds_[m.id] = *cloud;
      merged_clouds_[m.id] = std::move(cloud);
    }
  }
  if (added.empty()) {
    ++counters_.updates_rejected;
    outcome.status = UpdateOutcome::Status::kRejected;
    outcome.reason = "update without keyframes";
    return outcome;
  }
  // New submaps by Eq. 2, and the chain of the session's relative poses as edges.
  outcome.new_submaps = join_submaps(added, config_.submaps, next_submap_id);
  for (size_t i = 1; i < added.size(); ++i) {
    PoseGraphEdge e;
    e.from = added[i - 1].id;
    e.to = added[i].id;
    e.T_from_to = added[i - 1].T_map_body.inverse() * added[i].T_map_body;
    map_.edges.push_back(e);
  }
  map_.keyframes.insert(map_.keyframes.end(), added.begin(), added.end());
  map_.submaps.insert(map_.submaps.end(), outcome.new_submaps.begin(), outcome.new_submaps.end());
  database_ = SubmapDatabase(map_);
  ++counters_.updates_merged;
  counters_.keyframes_merged += static_cast<int64_t>(added.size());
  outcome.status = UpdateOutcome::Status::kMerged;
  outcome.new_keyframes = std::move(added);
  return outcome;
}

std::map<int64_t, PointCloud> MapService::take_new_clouds() {
  std::map<int64_t, PointCloud> out;
  out.swap(unsaved_clouds_);
  return out;
}

void MapService::saved(int64_t version, const std::vector<int64_t>& keyframe_ids) {
  map_.version = version;
  for (const int64_t id : keyframe_ids) {
    merged_clouds_.erase(id);
  }
}

}  // namespace liloc
