#include "map_client/map_client.hpp"

#include <spdlog/spdlog.h>

#include <stdexcept>

#include "bridge/map_conversions.hpp"
#include "node/convert.hpp"
#include "node/node.hpp"
#include "node/reply_route.hpp"

namespace liloc {

void MapClientConfig::validate() const {
  if (!(request_period_s > 0 && request_period_s <= 600) || max_cached_submaps < 1) {
    throw std::invalid_argument(
        "request_period_s must be in (0, 600], max_cached_submaps at least 1");
  }
}

MapClient::MapClient(transport::Transport& bus, const std::string& robot_id,
                     const transport::ChannelConfig& channels,
                     const PolarDescriptorConfig& descriptor, const MapClientConfig& config,
                     std::function<void()> on_ready)
    : bus_(bus),
      robot_id_(robot_id),
      channels_(channels),
      descriptor_(descriptor),
      config_(config),
      on_ready_(std::move(on_ready)),
      targets_([this](int64_t id) { return submap_points(id); },
               static_cast<size_t>(config.max_cached_submaps)) {
  config_.validate();
  const std::string reply_url =
      node::reply_url(bus.config().url, bus.config().reply_ports, robot_id);
  if (reply_url != bus.config().url) {
    transport::TransportConfig reply_config = bus.config();
    reply_config.url = reply_url;
    reply_config.publish_url.clear();
    replies_ = std::make_unique<transport::Transport>(reply_config);
  }
  transport::Transport& replies = replies_ ? *replies_ : bus_;
  bus_.subscribe<liloc::map_info_t>(
      channels.map_info, [this](const liloc::map_info_t& m, const transport::ReceiveInfo&) {
        const auto from = [](const liloc::map_info_t& msg) { return bridge::from_msg(msg); };
        if (auto info = node::convert(m, from, counters_.rejected_messages, "map info")) {
          on_map_info(std::move(*info));
        }
      });
  replies.subscribe<liloc::keyframe_descriptors_t>(
      transport::robot_channel(robot_id, channels.descriptors),
      [this](const liloc::keyframe_descriptors_t& m, const transport::ReceiveInfo&) {
        const auto from = [](const liloc::keyframe_descriptors_t& msg) {
          return bridge::from_msg(msg);
        };
        if (auto part =
                node::convert(m, from, counters_.rejected_messages, "keyframe index chunk")) {
          on_index_part(std::move(*part));
        }
      });
  replies.subscribe<liloc::submap_t>(
      transport::robot_channel(robot_id, channels.submap),
      [this](const liloc::submap_t& m, const transport::ReceiveInfo&) {
        const auto from = [](const liloc::submap_t& msg) { return bridge::from_msg(msg); };
        if (auto part = node::convert(m, from, counters_.rejected_messages, "submap reply")) {
          on_submap(std::move(*part));
        }
      });
}

std::vector<transport::Transport*> MapClient::own_transports() {
  return replies_ ? std::vector<transport::Transport*>{replies_.get()}
                  : std::vector<transport::Transport*>{};
}

std::string MapClient::waiting_for_index() const {
  return "waiting for the map's keyframe index from the map server (" +
         channels_.descriptor_request + ")";
}

void MapClient::on_map_info(MapData info) {
  const bool first = !map_info_;
  const int64_t version = info.version;
  map_info_ = std::move(info);
  if (first) {
    build_index();  // the index's chunks may have come before MAP.INFO
  }
  if (index_ && index_->version() != version && index_chunks_.empty()) {
    request_index(node::wall_clock_us());  // the map grew
  }
}

void MapClient::request_index(int64_t now_us) {
  index_chunks_.clear();
  liloc::descriptor_request_t request =
      bridge::to_msg(bridge::DescriptorRequest{robot_id_, ++index_request_id_, now_us});
  bus_.publish(channels_.descriptor_request, request);
  index_requested_us_ = now_us;
  ++counters_.index_requests;
}

void MapClient::on_index_part(KeyframeIndexPart part) {
  if (part.request_id != index_request_id_ || part.num_chunks < 1 || part.chunk_index < 0 ||
      part.chunk_index >= part.num_chunks) {
    return;  // an older request's, or malformed
  }
  const int chunk = part.chunk_index;
  index_chunks_[chunk] = std::move(part);
  build_index();
}

void MapClient::build_index() {
  if (index_chunks_.empty() || !map_info_ ||
      static_cast<int>(index_chunks_.size()) < index_chunks_.begin()->second.num_chunks) {
    return;
  }
  // The map as the index needs it: keyframes (pose, submap) and submaps (Tree_m).
  MapData map;
  map.version = index_chunks_.begin()->second.map_version;
  map.submaps = map_info_->submaps;
  KeyframeDescriptors descriptors;
  for (const auto& [index, chunk] : index_chunks_) {
    for (const IndexedKeyframe& kf : chunk.keyframes) {
      MapKeyframe m;
      m.id = kf.id;
      m.submap_id = kf.submap_id;
      m.T_map_body = kf.T_map_body;
      map.keyframes.push_back(m);
      descriptors[kf.id] = *kf.descriptor;
    }
  }
  index_chunks_.clear();
  try {
    index_ = std::make_unique<MapIndex>(map, descriptors, descriptor_);
  } catch (const std::invalid_argument& e) {
    ++counters_.rejected_messages;
    error_ = std::string("the map's keyframe index did not convert: ") + e.what();
    spdlog::error("{}: {}", robot_id_, error_);
    return;
  }
  error_.clear();
  spdlog::info("{}: map index of {} keyframes, {} submaps (version {})", robot_id_,
               index_->keyframes().size(), map.submaps.size(), map.version);
  on_ready_();
}

void MapClient::on_submap(SubmapReplyPart part) {
  const int64_t id = part.submap ? part.submap->id : -1;
  if (id < 0 || submaps_requested_us_.count(id) == 0) {
    return;  // nothing matched, or a submap this client did not ask for (or has)
  }
  std::vector<SubmapReplyPart>& chunks = submap_chunks_[id];
  if (!chunks.empty() && chunks.front().request_id != part.request_id) {
    chunks.clear();  // a newer request's reply: start over
  }
  const int num_chunks = part.num_chunks;
  chunks.push_back(std::move(part));
  if (static_cast<int>(chunks.size()) < num_chunks) {
    return;
  }
  auto points = std::make_shared<std::vector<Eigen::Vector3f>>();
  for (const SubmapReplyPart& chunk : chunks) {
    if (!chunk.clouds) {
      ++counters_.rejected_messages;  // a reply without clouds
      submap_chunks_.erase(id);
      return;  // asked again at the next period
    }
    for (size_t k = 0; k < chunk.keyframes.size(); ++k) {
      const Eigen::Isometry3f T = chunk.keyframes[k].T_map_body.cast<float>();
      for (const Eigen::Vector3f& p : chunk.clouds->keyframe_cloud(k).points) {
        points->push_back(T * p);
      }
    }
  }
  submap_chunks_.erase(id);
  submaps_requested_us_.erase(id);
  submaps_[id] = std::move(points);
  submap_order_.push_back(id);
  while (submap_order_.size() > static_cast<size_t>(config_.max_cached_submaps)) {
    submaps_.erase(submap_order_.front());
    submap_order_.pop_front();
  }
  if (submaps_requested_us_.empty()) {
    on_ready_();
  }
}

std::shared_ptr<const std::vector<Eigen::Vector3f>> MapClient::submap_points(int64_t id) const {
  const auto it = submaps_.find(id);
  return it == submaps_.end() ? nullptr : it->second;
}

void MapClient::request_submaps(const std::vector<int64_t>& ids, int64_t now_us) {
  const int64_t period_us = static_cast<int64_t>(config_.request_period_s * 1e6);
  // The server answers at most a few submaps per request: one request per submap.
  for (const int64_t id : ids) {
    const auto asked = submaps_requested_us_.find(id);
    if (asked != submaps_requested_us_.end() && now_us - asked->second < period_us) {
      continue;
    }
    SubmapQuery q;
    q.robot_id = robot_id_;
    q.request_id = ++submap_request_id_;
    q.by_id = true;
    q.submap_ids = {id};
    q.include_clouds = true;
    liloc::submap_request_t msg = bridge::to_msg(q, now_us);
    bus_.publish(channels_.map_request, msg);
    submaps_requested_us_[id] = now_us;
    ++counters_.submap_requests;
  }
}

void MapClient::tick(int64_t now_us) {
  const int64_t period_us = static_cast<int64_t>(config_.request_period_s * 1e6);
  const bool stale = !index_ || (map_info_ && index_->version() != map_info_->version);
  if (stale && now_us - index_requested_us_ >= period_us) {
    request_index(now_us);  // the server may have started after us, or restarted
  }
  std::vector<int64_t> unanswered;
  for (const auto& [id, asked_us] : submaps_requested_us_) {
    unanswered.push_back(id);
  }
  request_submaps(unanswered, now_us);
}

}  // namespace liloc
