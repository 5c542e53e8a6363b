#include "initializer_node/initializer_node.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <stdexcept>

#include "app/rate_limit.hpp"
#include "bridge/init_conversions.hpp"
#include "bridge/lcm_conversions.hpp"
#include "bridge/map_conversions.hpp"
#include "bridge/status_report.hpp"
#include "node/reply_route.hpp"

namespace liloc {
namespace {

// A message's core value, or none if it does not convert (counted in `rejected`, logged
// rate-limited with the reason).
template <class Msg, class Convert>
auto convert(const Msg& msg, Convert convert_msg, int64_t& rejected, const std::string& what)
    -> std::optional<decltype(convert_msg(msg))> {
  try {
    return convert_msg(msg);
  } catch (const std::invalid_argument& e) {
    if (should_log(++rejected)) {
      spdlog::warn("{} refused: {} ({} messages refused so far)", what, e.what(), rejected);
    }
    return std::nullopt;
  }
}

}  // namespace

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
      [this](const liloc::keyframe_t& m, const transport::ReceiveInfo&) {
        ++counters_.keyframes;
        if (!wanted_) {
          return;  // its cloud is not even decoded
        }
        if (auto query =
                convert(m, bridge::init_query_from_msg, counters_.rejected_messages, "keyframe")) {
          on_keyframe(std::move(*query));
        }
      });
  bus_.subscribe<liloc::pose_t>(
      channel(config.channels.coarse_pose),
      [this](const liloc::pose_t& m, const transport::ReceiveInfo&) {
        if (auto coarse = convert(m, bridge::coarse_pose_from_msg, counters_.rejected_messages,
                                  "coarse pose")) {
          on_coarse_pose(*coarse);
        }
      });
  bus_.subscribe<liloc::map_info_t>(
      config.channels.map_info, [this](const liloc::map_info_t& m, const transport::ReceiveInfo&) {
        const auto from = [](const liloc::map_info_t& msg) { return bridge::from_msg(msg); };
        if (auto info = convert(m, from, counters_.rejected_messages, "map info")) {
          on_map_info(std::move(*info));
        }
      });
  replies.subscribe<liloc::keyframe_descriptors_t>(
      channel(config.channels.descriptors),
      [this](const liloc::keyframe_descriptors_t& m, const transport::ReceiveInfo&) {
        const auto from = [](const liloc::keyframe_descriptors_t& msg) {
          return bridge::from_msg(msg);
        };
        if (auto part = convert(m, from, counters_.rejected_messages, "keyframe index chunk")) {
          on_descriptors(std::move(*part));
        }
      });
  replies.subscribe<liloc::submap_t>(
      channel(config.channels.submap),
      [this](const liloc::submap_t& m, const transport::ReceiveInfo&) {
        const auto from = [](const liloc::submap_t& msg) { return bridge::from_msg(msg); };
        if (auto part = convert(m, from, counters_.rejected_messages, "submap reply")) {
          on_submap(std::move(*part));
        }
      });
}

std::vector<transport::Transport*> InitializerNode::own_transports() {
  return replies_ ? std::vector<transport::Transport*>{replies_.get()}
                  : std::vector<transport::Transport*>{};
}

void InitializerNode::on_keyframe(InitQuery query) {
  keyframes_.push_back(std::move(query));
  while (keyframes_.size() > 10) {
    keyframes_.pop_front();
  }
  try_initialize();
}

void InitializerNode::on_coarse_pose(const CoarsePose& coarse) {
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

void InitializerNode::on_map_info(MapData info) {
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

void InitializerNode::request_index(int64_t now_us) {
  index_chunks_.clear();
  liloc::descriptor_request_t request =
      bridge::to_msg(bridge::DescriptorRequest{robot_id_, ++index_request_id_, now_us});
  bus_.publish(config_.channels.descriptor_request, request);
  index_requested_us_ = now_us;
  ++counters_.index_requests;
}

void InitializerNode::on_descriptors(KeyframeIndexPart part) {
  if (part.request_id != index_request_id_ || part.num_chunks < 1 || part.chunk_index < 0 ||
      part.chunk_index >= part.num_chunks) {
    return;  // an older request's, or malformed
  }
  const int chunk = part.chunk_index;
  index_chunks_[chunk] = std::move(part);
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
  try {
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

void InitializerNode::on_submap(SubmapReplyPart part) {
  const int64_t id = part.submap ? part.submap->id : -1;
  if (id < 0 || submaps_requested_us_.count(id) == 0) {
    return;  // nothing matched, or a submap this node did not ask for (or has)
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
  const bool stale = !index_ || (map_info_ && index_->version() != map_info_->version);
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
