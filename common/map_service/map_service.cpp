#include "map_service/map_service.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "map/map_validation.hpp"

namespace liloc {

void MapServiceConfig::validate() const {
  if (max_submaps_per_reply < 1 || max_chunk_points < 1 || max_descriptor_chunk_bytes < 1024 ||
      max_update_keyframes < 1 || max_update_points < 1 || !(update_timeout_s > 0) ||
      reply_cache_submaps < 1 || max_finished_updates < 1 || max_pending_updates < 1 ||
      max_pending_points < 1) {
    throw std::invalid_argument("limits and timeout must be positive");
  }
  for (const std::string& robot : allowed_robots) {
    if (!is_valid_name(robot)) {
      throw std::invalid_argument("allowed robot '" + robot + "' is not a valid name");
    }
  }
  if (!(reply_voxel_m >= 0.0)) {
    throw std::invalid_argument("reply_voxel_m must be >= 0");
  }
}

MapService::MapService(MapData map, KeyframeCloudSource clouds,
                       const KeyframeDescriptors& descriptors, const MapServiceConfig& config,
                       const SubmapConfig& submaps, const PolarDescriptorConfig& descriptor,
                       const SubmapCloudStore* store)
    : map_(std::move(map)),
      cloud_source_(std::move(clouds)),
      config_(config),
      submaps_(submaps),
      descriptor_(descriptor),
      store_(store),
      database_(map_) {
  config_.validate();
  submaps_.validate();
  descriptor_.validate();
  for (const auto& [id, bytes] : descriptors) {
    descriptors_[id] = std::make_shared<const std::vector<uint8_t>>(bytes);
  }
  if (store_ != nullptr && store_->voxel_m() != config_.reply_voxel_m) {
    throw std::invalid_argument("the submap cloud store's voxel size (" +
                                std::to_string(store_->voxel_m()) + " m) is not reply_voxel_m (" +
                                std::to_string(config_.reply_voxel_m) + " m)");
  }
}

std::vector<SubmapReplyPart> MapService::answer(const SubmapQuery& query) {
  ReplyPlan reply = plan(query);
  std::vector<SubmapReplyPart> parts = complete(reply);
  remember(reply);
  return parts;
}

MapService::ReplyPlan MapService::plan(const SubmapQuery& query) {
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
  counters_.empty_replies += ids.empty() ? 1 : 0;

  ReplyPlan reply;
  reply.query = query;
  reply.map_version = map_.version;
  reply.generation = generation_;
  for (const int64_t id : ids) {
    ReplyPlan::Item item;
    item.submap = *database_.submap(id);
    for (const int64_t kf_id : item.submap.keyframe_ids) {
      item.keyframes.push_back(*database_.keyframe(kf_id));
    }
    if (query.include_clouds) {
      const auto cached = reply_clouds_.find(id);
      if (cached != reply_clouds_.end()) {
        item.clouds = cached->second;
        // Least recently used goes first.
        reply_clouds_order_.erase(
            std::find(reply_clouds_order_.begin(), reply_clouds_order_.end(), id));
        reply_clouds_order_.push_back(id);
      } else {
        // Merged clouds not yet saved live here; the others come from the cloud source.
        for (const int64_t kf_id : item.submap.keyframe_ids) {
          const auto merged = merged_clouds_.find(kf_id);
          item.sources.push_back(merged != merged_clouds_.end() ? merged->second : nullptr);
        }
      }
    }
    reply.items.push_back(std::move(item));
  }
  return reply;
}

std::vector<KeyframeIndexPart> MapService::keyframe_index(const std::string& robot_id,
                                                          int64_t request_id) const {
  std::vector<KeyframeIndexPart> parts;
  size_t bytes = 0;
  for (const MapKeyframe& kf : map_.keyframes) {
    const auto descriptor = descriptors_.find(kf.id);
    if (descriptor == descriptors_.end()) {
      continue;  // a keyframe without one is not searched
    }
    if (parts.empty() || (bytes + descriptor->second->size() >
                              static_cast<size_t>(config_.max_descriptor_chunk_bytes) &&
                          !parts.back().keyframes.empty())) {
      KeyframeIndexPart& part = parts.emplace_back();
      part.robot_id = robot_id;
      part.request_id = request_id;
      part.map_version = map_.version;
      bytes = 0;
    }
    parts.back().keyframes.push_back({kf.id, kf.submap_id, kf.T_map_body, descriptor->second});
    bytes += descriptor->second->size();
  }
  if (parts.empty()) {  // a map without descriptors: one empty part says so
    KeyframeIndexPart& part = parts.emplace_back();
    part.robot_id = robot_id;
    part.request_id = request_id;
    part.map_version = map_.version;
  }
  for (size_t i = 0; i < parts.size(); ++i) {
    parts[i].chunk_index = static_cast<int>(i);
    parts[i].num_chunks = static_cast<int>(parts.size());
  }
  return parts;
}

std::vector<SubmapReplyPart> MapService::complete(ReplyPlan& reply) const {
  const SubmapQuery& query = reply.query;
  const auto base = [&]() {
    SubmapReplyPart p;
    p.robot_id = query.robot_id;
    p.request_id = query.request_id;
    p.map_version = reply.map_version;
    return p;
  };
  std::vector<SubmapReplyPart> parts;
  if (reply.items.empty()) {
    SubmapReplyPart p = base();
    p.reply_count = 1;
    parts.push_back(std::move(p));
    return parts;
  }
  for (ReplyPlan::Item& item : reply.items) {
    if (query.include_clouds && !item.clouds) {
      item.clouds = reply_clouds(item);
      item.computed = true;
    }
    // Chunks of whole keyframes [first, end), each under max_chunk_points.
    std::vector<SubmapReplyPart> chunks;
    const auto add_chunk = [&](size_t first, size_t end) {
      SubmapReplyPart& chunk = chunks.emplace_back(base());
      chunk.submap = item.submap;
      chunk.keyframes.assign(item.keyframes.begin() + static_cast<ptrdiff_t>(first),
                             item.keyframes.begin() + static_cast<ptrdiff_t>(end));
      if (query.include_clouds) {
        chunk.clouds = item.clouds->keyframe_range(first, end);
      }
    };
    size_t first = 0;
    int64_t points = 0;
    for (size_t k = 0; k < item.keyframes.size(); ++k) {
      const auto n = query.include_clouds ? static_cast<int64_t>(item.clouds->points_of(k)) : 0;
      if (k > first && points + n > config_.max_chunk_points) {
        add_chunk(first, k);
        first = k;
        points = 0;
      }
      points += n;
    }
    add_chunk(first, item.keyframes.size());
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

std::shared_ptr<const SubmapClouds> MapService::reply_clouds(const ReplyPlan::Item& item) const {
  if (store_ != nullptr) {
    if (std::optional<SubmapClouds> stored = store_->load(item.submap, item.keyframes)) {
      return std::make_shared<const SubmapClouds>(std::move(*stored));
    }
  }
  KeyframeClouds full;
  for (size_t k = 0; k < item.keyframes.size(); ++k) {
    full.push_back(item.sources[k] ? item.sources[k] : cloud_source_(item.keyframes[k].id));
  }
  auto out = std::make_shared<const SubmapClouds>(
      deduplicate_submap_clouds(item.keyframes, full, config_.reply_voxel_m));
  if (store_ != nullptr) {
    try {
      store_->save(item.submap, item.keyframes, *out);
    } catch (const std::exception&) {
      ++store_errors_;  // the reply does not need it; the next request tries again
    }
  }
  return out;
}

void MapService::remember(const ReplyPlan& reply) {
  if (reply.generation != generation_) {
    return;  // the map changed meanwhile: what was computed may be stale
  }
  for (const ReplyPlan::Item& item : reply.items) {
    if (!item.computed || reply_clouds_.count(item.submap.id) > 0) {
      continue;
    }
    if (static_cast<int>(reply_clouds_order_.size()) >= config_.reply_cache_submaps) {
      reply_clouds_.erase(reply_clouds_order_.front());
      reply_clouds_order_.pop_front();
    }
    reply_clouds_order_.push_back(item.submap.id);
    reply_clouds_[item.submap.id] = item.clouds;
  }
}

std::optional<std::string> MapService::validate(const MapUpdatePart& part) const {
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

UpdateOutcome MapService::refuse(int64_t& counter, const std::string& reason) {
  ++counter;
  UpdateOutcome outcome;
  outcome.status = UpdateOutcome::Status::kRejected;
  outcome.reason = reason;
  return outcome;
}

UpdateOutcome MapService::reject(const std::string& robot_id, const std::string& session_id,
                                 int64_t update_id, const std::string& reason) {
  const UpdateKey key(robot_id, session_id, update_id);
  if (finished_.count(key) != 0) {
    ++counters_.updates_repeated;
    return {};  // a part of a merged update: nothing to do
  }
  pending_.erase(key);
  return refuse(counters_.updates_rejected, reason);
}

void MapService::remember_merged(const UpdateKey& key) {
  pending_.erase(key);
  if (finished_.insert(key).second) {
    finished_order_.push_back(key);
  }
  while (finished_order_.size() > static_cast<size_t>(config_.max_finished_updates)) {
    finished_.erase(finished_order_.front());
    finished_order_.pop_front();
  }
}

UpdateOutcome MapService::receive(MapUpdatePart part, int64_t now_us) {
  const UpdateKey key(part.robot_id, part.session_id, part.update_id);
  if (finished_.count(key) != 0) {
    ++counters_.updates_repeated;
    return {};  // a part of a merged update: nothing to do
  }
  if (std::find(config_.allowed_robots.begin(), config_.allowed_robots.end(), part.robot_id) ==
      config_.allowed_robots.end()) {
    return refuse(counters_.updates_refused_robot,
                  "robot '" + printable_excerpt(part.robot_id) +
                      "' may not update the map (map_server.service.allowed_robots)");
  }
  if (const std::optional<std::string> problem = validate(part)) {
    return reject(part.robot_id, part.session_id, part.update_id, *problem);
  }
  int64_t points = 0;
  for (const UpdateKeyframe& kf : part.keyframes) {
    points += static_cast<int64_t>(kf.cloud_body.size());
  }
  if (pending_.count(key) == 0 && part.num_chunks > 1) {
    int64_t pending_points = 0;
    for (const auto& entry : pending_) {
      pending_points += entry.second.points;
    }
    if (static_cast<int>(pending_.size()) >= config_.max_pending_updates ||
        pending_points + points > config_.max_pending_points) {
      return refuse(counters_.updates_refused_busy,
                    std::to_string(pending_.size()) + " updates with " +
                        std::to_string(pending_points) +
                        " points already wait for their chunks (max_pending_updates, "
                        "max_pending_points)");
    }
  }
  PendingUpdate& update = pending_[key];
  if (update.chunks.empty()) {
    update.num_chunks = part.num_chunks;
    update.first_seen_us = now_us;
  } else if (update.num_chunks != part.num_chunks) {
    return reject(part.robot_id, part.session_id, part.update_id,
                  "parts disagree on the number of chunks");
  }
  update.points += points;
  if (update.points > config_.max_update_points) {
    return reject(part.robot_id, part.session_id, part.update_id,
                  std::to_string(update.points) + " points, more than " +
                      std::to_string(config_.max_update_points));
  }
  update.chunks[part.chunk_index] = std::move(part.keyframes);
  if (static_cast<int>(update.chunks.size()) < update.num_chunks) {
    return {};
  }
  const auto& [robot, session, id] = key;
  UpdateOutcome outcome = merge(robot, session, update);
  if (outcome.status == UpdateOutcome::Status::kRejected) {
    return reject(robot, session, id, outcome.reason);
  }
  remember_merged(key);
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

UpdateOutcome MapService::merge(const std::string& robot_id, const std::string& session_id,
                                PendingUpdate& update) {
  UpdateOutcome outcome;
  outcome.status = UpdateOutcome::Status::kRejected;
  int64_t next_keyframe_id = map_.keyframes.empty() ? 0 : map_.keyframes.back().id + 1;
  const int64_t next_submap_id = map_.submaps.empty() ? 0 : map_.submaps.back().id + 1;
  MapDelta delta;
  for (auto& [index, keyframes] : update.chunks) {
    for (UpdateKeyframe& kf : keyframes) {
      MapKeyframe m;
      m.id = next_keyframe_id++;
      m.utime_us = kf.utime_us;
      m.session = session_id.empty() ? robot_id : session_id;
      m.T_map_body = kf.T_map_body;
      m.fitness_m = kf.fitness_m;
      auto cloud = std::make_shared<const PointCloud>(std::move(kf.cloud_body));
      delta.descriptors[m.id] =
          encode(make_level_polar_descriptor(*cloud, m.T_map_body.linear(), descriptor_));
      delta.keyframes.push_back(m);
      delta.clouds[m.id] = std::move(cloud);
    }
  }
  if (delta.keyframes.empty()) {
    outcome.reason = "update without keyframes";
    return outcome;
  }
  // New submaps by Eq. 2, and the chain of the session's relative poses as edges.
  delta.submaps = join_submaps(delta.keyframes, submaps_, next_submap_id);
  for (size_t i = 1; i < delta.keyframes.size(); ++i) {
    PoseGraphEdge e;
    e.from = delta.keyframes[i - 1].id;
    e.to = delta.keyframes[i].id;
    e.T_from_to = delta.keyframes[i - 1].T_map_body.inverse() * delta.keyframes[i].T_map_body;
    delta.edges.push_back(e);
  }
  // The rules a save checks, on the map as it would be: what is merged can be saved.
  MapData merged = map_;
  delta.append_to(merged);
  if (const std::optional<MapProblem> problem = find_map_problem(merged)) {
    outcome.reason = problem->what;
    return outcome;
  }
  map_ = std::move(merged);
  database_ = SubmapDatabase(map_);
  merged_clouds_.insert(delta.clouds.begin(), delta.clouds.end());
  for (const auto& [id, bytes] : delta.descriptors) {
    descriptors_[id] = std::make_shared<const std::vector<uint8_t>>(bytes);
  }
  ++counters_.updates_merged;
  reply_clouds_.clear();  // a merge may re-cut submaps: recompute what replies send
  reply_clouds_order_.clear();
  ++generation_;
  counters_.keyframes_merged += static_cast<int64_t>(delta.keyframes.size());
  outcome.status = UpdateOutcome::Status::kMerged;
  outcome.new_keyframes = delta.keyframes;
  outcome.new_submaps = delta.submaps;
  delta.append_to(unsaved_);
  return outcome;
}

MapDelta MapService::take_unsaved() {
  MapDelta out;
  std::swap(out, unsaved_);
  return out;
}

void MapService::saved(int64_t version, const std::vector<int64_t>& keyframe_ids) {
  map_.version = version;
  for (const int64_t id : keyframe_ids) {
    merged_clouds_.erase(id);
  }
}

}  // namespace liloc
