#include "initializer_node/initializer_node.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <stdexcept>

#include "app/rate_limit.hpp"
#include "bridge/init_conversions.hpp"
#include "bridge/lcm_conversions.hpp"
#include "bridge/map_conversions.hpp"
#include "bridge/status_report.hpp"
#include "liloc/descriptor_request_t.hpp"
#include "liloc/status_t.hpp"
#include "liloc/submap_request_t.hpp"
#include "node/reply_route.hpp"

namespace liloc {

void InitializerProcessConfig::validate() const {
  if (!(global_sigma_xy_m > 0) || !(request_period_s > 0 && request_period_s <= 600) ||
      !(status_period_s > 0 && status_period_s <= 600) || max_cached_submaps < 1) {
    throw std::invalid_argument(
        "global_sigma_xy_m must be positive, request_period_s and status_period_s in (0, 600], "
        "max_cached_submaps at least 1");
  }
  search.validate();
}

InitializerNode::InitializerNode(transport::Transport& bus, const std::string& robot_id,
                                 const InitializerNodeConfig& config)
    : bus_(bus),
      robot_id_(robot_id),
      config_(config),
      initializer_(config.initializer.search, config.descriptor),
      voter_(config.initializer.voting),
      targets_([this](int64_t id) { return submap_points(id); },
               static_cast<size_t>(config.initializer.max_cached_submaps)),
      state_("waiting for a keyframe") {
  config_.initializer.validate();
  const std::string reply_url =
      node::reply_url(bus.config().url, bus.config().reply_ports, robot_id);
  if (reply_url != bus.config().url) {
    transport::TransportConfig reply_config = bus.config();
    reply_config.url = reply_url;
    reply_config.publish_url.clear();
    replies_ = std::make_unique<transport::Transport>(reply_config);
  }
  transport::Transport& replies = replies_ ? *replies_ : bus_;
  const auto channel = [&](const std::string& suffix) {
    return transport::robot_channel(robot_id, suffix);
  };
  init_channel_ = channel(config.channels.init);
  status_channel_ = channel(config.channels.status) + ".initializer";
  bus_.subscribe<liloc::keyframe_t>(
      channel(config.channels.keyframe),
      [this](const liloc::keyframe_t& m, const transport::ReceiveInfo&) { on_keyframe(m); });
  bus_.subscribe<liloc::pose_t>(
      channel(config.channels.coarse_pose),
      [this](const liloc::pose_t& m, const transport::ReceiveInfo&) { on_coarse_pose(m); });
  bus_.subscribe<liloc::map_info_t>(
      config.channels.map_info,
      [this](const liloc::map_info_t& m, const transport::ReceiveInfo&) { on_map_info(m); });
  replies.subscribe<liloc::keyframe_descriptors_t>(
      channel(config.channels.descriptors),
      [this](const liloc::keyframe_descriptors_t& m, const transport::ReceiveInfo&) {
        on_descriptors(m);
      });
  replies.subscribe<liloc::submap_t>(
      channel(config.channels.submap),
      [this](const liloc::submap_t& m, const transport::ReceiveInfo&) { on_submap(m); });
}

std::vector<transport::Transport*> InitializerNode::own_transports() {
  return replies_ ? std::vector<transport::Transport*>{replies_.get()}
                  : std::vector<transport::Transport*>{};
}

void InitializerNode::on_keyframe(const liloc::keyframe_t& msg) {
  ++counters_.keyframes;
  if (!wanted_) {
    return;
  }
  InitQuery query;
  query.keyframe_id = msg.keyframe_id;
  query.utime_us = msg.header.utime;
  try {
    query.T_odom_body = bridge::from_msg(msg.pose);
  } catch (const std::invalid_argument&) {
    ++counters_.rejected_messages;
    return;
  }
  query.cloud_body = bridge::from_msg(msg.cloud);
  keyframes_.push_back(std::move(query));
  while (keyframes_.size() > 10) {
    keyframes_.pop_front();
  }
  try_initialize();
}

void InitializerNode::on_coarse_pose(const liloc::pose_t& msg) {
  CoarsePose coarse;
  try {
    coarse = bridge::coarse_pose_from_msg(msg);
  } catch (const std::invalid_argument& e) {
    ++counters_.rejected_messages;
    spdlog::warn("{}: coarse pose refused: {}", robot_id_, e.what());
    return;
  }
  // A request to (re-)initialize; a pose this uncertain asks for a global search.
  if (coarse.sigma_xy_m > config_.initializer.global_sigma_xy_m) {
    coarse_.reset();
  } else {
    coarse_ = coarse;
  }
  wanted_ = true;
  voter_.clear();
  spdlog::info("{}: initialization asked for ({})", robot_id_,
               coarse_ ? "coarse pose given" : "global search");
  try_initialize();
}

void InitializerNode::on_map_info(const liloc::map_info_t& msg) {
  const bool first = !map_info_;
  map_info_ = msg;
  if (first) {
    build_index();  // the index's chunks may have come before MAP.INFO
  }
  if (index_ && index_->version() != msg.map_version && index_chunks_.empty()) {
    request_index(node::wall_clock_us());  // the map grew
  }
}

void InitializerNode::request_index(int64_t now_us) {
  liloc::descriptor_request_t request;
  request.header = bridge::make_header(now_us, robot_id_, "map");
  request.request_id = ++index_request_id_;
  index_chunks_.clear();
  bus_.publish(config_.channels.descriptor_request, request);
  index_requested_us_ = now_us;
  ++counters_.index_requests;
}

void InitializerNode::on_descriptors(const liloc::keyframe_descriptors_t& msg) {
  if (msg.request_id != index_request_id_ || msg.num_chunks < 1 || msg.chunk_index < 0 ||
      msg.chunk_index >= msg.num_chunks) {
    return;  // an older request's, or malformed
  }
  index_chunks_[msg.chunk_index] = msg;
  build_index();
}

void InitializerNode::build_index() {
  if (index_chunks_.empty() || !map_info_ ||
      static_cast<int>(index_chunks_.size()) < index_chunks_.begin()->second.num_chunks) {
    return;
  }
  // The map as the index needs it: keyframes (pose, submap) and submaps (Tree_m).
  MapData map;
  map.version = index_chunks_.begin()->second.map_version;
  KeyframeDescriptors descriptors;
  try {
    for (const auto& [index, chunk] : index_chunks_) {
      for (const IndexedKeyframe& kf : bridge::from_msg(chunk).keyframes) {
        MapKeyframe m;
        m.id = kf.id;
        m.submap_id = kf.submap_id;
        m.T_map_body = kf.T_map_body;
        map.keyframes.push_back(m);
        descriptors[kf.id] = *kf.descriptor;
      }
    }
    for (const liloc::submap_info_t& info : map_info_->submaps) {
      Submap s;
      s.id = info.submap_id;
      s.centroid = Eigen::Vector3d(info.centroid[0], info.centroid[1], info.centroid[2]);
      s.bounds = {info.bounds_xy[0], info.bounds_xy[1], info.bounds_xy[2], info.bounds_xy[3]};
      map.submaps.push_back(s);
    }
    index_ = std::make_unique<MapIndex>(map, descriptors, config_.descriptor);
  } catch (const std::invalid_argument& e) {
    ++counters_.rejected_messages;
    state_ = std::string("the map's keyframe index did not convert: ") + e.what();
    spdlog::error("{}: {}", robot_id_, state_);
    index_chunks_.clear();
    return;
  }
  index_chunks_.clear();
  spdlog::info("{}: map index of {} keyframes, {} submaps (version {})", robot_id_,
               index_->keyframes().size(), map.submaps.size(), map.version);
  try_initialize();
}

void InitializerNode::on_submap(const liloc::submap_t& msg) {
  if (msg.submap_id < 0 || submaps_requested_us_.count(msg.submap_id) == 0) {
    return;  // nothing matched, or a submap this node did not ask for (or has)
  }
  std::vector<liloc::submap_t>& chunks = submap_chunks_[msg.submap_id];
  if (!chunks.empty() && chunks.front().request_id != msg.request_id) {
    chunks.clear();  // a newer request's reply: start over
  }
  chunks.push_back(msg);
  if (static_cast<int>(chunks.size()) < msg.num_chunks) {
    return;
  }
  auto points = std::make_shared<std::vector<Eigen::Vector3f>>();
  try {
    for (const liloc::submap_t& chunk : chunks) {
      const SubmapReplyPart part = bridge::from_msg(chunk);
      if (!part.clouds) {
        throw std::invalid_argument("a reply without clouds");
      }
      for (size_t k = 0; k < part.keyframes.size(); ++k) {
        const Eigen::Isometry3f T = part.keyframes[k].T_map_body.cast<float>();
        for (const Eigen::Vector3f& p : part.clouds->keyframe_cloud(k).points) {
          points->push_back(T * p);
        }
      }
    }
  } catch (const std::invalid_argument& e) {
    ++counters_.rejected_messages;
    submap_chunks_.erase(msg.submap_id);
    return;  // asked again at the next period
  }
  submap_chunks_.erase(msg.submap_id);
  submaps_requested_us_.erase(msg.submap_id);
  submaps_[msg.submap_id] = std::move(points);
  submap_order_.push_back(msg.submap_id);
  while (submap_order_.size() > static_cast<size_t>(config_.initializer.max_cached_submaps)) {
    submaps_.erase(submap_order_.front());
    submap_order_.pop_front();
  }
  if (submaps_requested_us_.empty()) {
    try_initialize();
  }
}

std::shared_ptr<const std::vector<Eigen::Vector3f>> InitializerNode::submap_points(
    int64_t id) const {
  const auto it = submaps_.find(id);
  return it == submaps_.end() ? nullptr : it->second;
}

void InitializerNode::request_submaps(const std::vector<int64_t>& ids, int64_t now_us) {
  const int64_t period_us = static_cast<int64_t>(config_.initializer.request_period_s * 1e6);
  std::vector<int64_t> due;
  for (const int64_t id : ids) {
    const auto asked = submaps_requested_us_.find(id);
    if (asked == submaps_requested_us_.end() || now_us - asked->second >= period_us) {
      due.push_back(id);
    }
  }
  // The server answers at most a few submaps per request: one request per submap.
  for (const int64_t id : due) {
    SubmapQuery q;
    q.robot_id = robot_id_;
    q.request_id = ++submap_request_id_;
    q.by_id = true;
    q.submap_ids = {id};
    q.include_clouds = true;
    liloc::submap_request_t msg = bridge::to_msg(q, now_us);
    bus_.publish(config_.channels.map_request, msg);
    submaps_requested_us_[id] = now_us;
    ++counters_.submap_requests;
  }
}

void InitializerNode::try_initialize() {
  if (!wanted_ || keyframes_.empty()) {
    return;
  }
  if (!index_) {
    state_ = "waiting for the map's keyframe index from the map server (" +
             config_.channels.descriptor_request + ")";
    return;
  }
  if (!coarse_ && !config_.initializer.global_without_coarse) {
    state_ = "waiting for a coarse pose on " +
             transport::robot_channel(robot_id_, config_.channels.coarse_pose);
    return;
  }
  const InitQuery& query = keyframes_.back();
  const InitResult result = coarse_
                                ? initializer_.coarse_to_fine(*index_, query, *coarse_, targets_)
                                : initializer_.global(*index_, query, targets_);
  if (result.status == InitResult::Status::kNeedsSubmaps) {
    request_submaps(result.missing_submaps, node::wall_clock_us());
    state_ = "fetching " + std::to_string(result.missing_submaps.size()) +
             " submap(s) from the map server";
    return;
  }
  ++counters_.attempts;
  InitAnswer answer = answer_of(result, query);
  if (!answer.localized && !coarse_) {
    // Keyframes tied by the odometry vote on the places each found plausible.
    if (const std::optional<Eigen::Isometry3d> T_map_odom = voter_.add(query, result.candidates)) {
      answer.localized = true;
      answer.T_map_body = *T_map_odom * query.T_odom_body;
      answer.method = "global, keyframes voting";
      answer.message = "keyframes agree: " + voter_.summary();
    }
  }
  publish(answer);
  if (answer.localized) {
    ++counters_.localized;
    spdlog::info("{}: localized keyframe {} ({}): {}", robot_id_, answer.keyframe_id, answer.method,
                 answer.message);
    state_ =
        "localized keyframe " + std::to_string(answer.keyframe_id) + " (" + answer.method + ")";
    wanted_ = false;
    coarse_.reset();
    voter_.clear();
    keyframes_.clear();
  } else {
    ++counters_.not_localized;
    state_ = "not localized (trying the next keyframes): " + answer.message;
    if (should_log(counters_.not_localized)) {
      spdlog::warn("{}: {}", robot_id_, state_);
    }
  }
}

void InitializerNode::publish(const InitAnswer& answer) {
  liloc::init_result_t msg = bridge::to_msg(answer, robot_id_);
  bus_.publish(init_channel_, msg);
}

void InitializerNode::tick(int64_t now_us) {
  const int64_t period_us = static_cast<int64_t>(config_.initializer.request_period_s * 1e6);
  const bool stale = !index_ || (map_info_ && index_->version() != map_info_->map_version);
  if (stale && now_us - index_requested_us_ >= period_us) {
    request_index(now_us);  // the server may have started after us, or restarted
  }
  std::vector<int64_t> unanswered;
  for (const auto& [id, asked_us] : submaps_requested_us_) {
    if (now_us - asked_us >= period_us) {
      unanswered.push_back(id);
    }
  }
  request_submaps(unanswered, now_us);
  if (now_us - last_status_us_ >= static_cast<int64_t>(config_.initializer.status_period_s * 1e6)) {
    publish_status(now_us);
  }
}

void InitializerNode::publish_status(int64_t now_us) {
  bridge::StatusReport report;
  report.process = "initializer";
  report.mode = wanted_ ? liloc::status_t::MODE_INITIALIZING : liloc::status_t::MODE_NONE;
  report.message = state_;
  report.counters = {
      {"keyframes", counters_.keyframes},
      {"attempts", counters_.attempts},
      {"localized", counters_.localized},
      {"not_localized", counters_.not_localized},
      {"index_requests", counters_.index_requests},
      {"submap_requests", counters_.submap_requests},
      {"rejected_messages", counters_.rejected_messages},
      {"index_keyframes", index_ ? static_cast<int64_t>(index_->keyframes().size()) : 0},
      {"cached_submaps", static_cast<int64_t>(submaps_.size())}};
  report.add_transport_counters(bus_);
  liloc::status_t status = bridge::to_msg(report, now_us, robot_id_);
  bus_.publish(status_channel_, status);
  last_status_us_ = now_us;
}

}  // namespace liloc
