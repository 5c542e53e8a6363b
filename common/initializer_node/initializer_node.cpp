#include "initializer_node/initializer_node.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <stdexcept>

#include "app/rate_limit.hpp"
#include "bridge/init_conversions.hpp"
#include "bridge/status_report.hpp"
#include "node/convert.hpp"

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
      map_(bus, robot_id, config.channels, config.descriptor,
           {config.initializer.request_period_s, config.initializer.max_cached_submaps},
           [this] { try_initialize(); }),
      state_("waiting for a keyframe") {
  config_.initializer.validate();
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
        if (auto query = node::convert(m, bridge::init_query_from_msg, counters_.rejected_messages,
                                       "keyframe")) {
          on_keyframe(std::move(*query));
        }
      });
  bus_.subscribe<liloc::pose_t>(
      channel(config.channels.coarse_pose),
      [this](const liloc::pose_t& m, const transport::ReceiveInfo&) {
        if (auto coarse = node::convert(m, bridge::coarse_pose_from_msg,
                                        counters_.rejected_messages, "coarse pose")) {
          on_coarse_pose(*coarse);
        }
      });
}

std::vector<transport::Transport*> InitializerNode::own_transports() {
  return map_.own_transports();
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
  global_asked_ = coarse.sigma_xy_m > config_.initializer.global_sigma_xy_m;
  if (global_asked_) {
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

void InitializerNode::try_initialize() {
  if (!wanted_ || keyframes_.empty()) {
    return;
  }
  const MapIndex* index = map_.index();
  if (index == nullptr) {
    state_ = map_.error().empty() ? map_.waiting_for_index() : map_.error();
    return;
  }
  if (!coarse_ && !global_asked_ && !config_.initializer.global_without_coarse) {
    state_ = "waiting for a coarse pose on " +
             transport::robot_channel(robot_id_, config_.channels.coarse_pose);
    return;
  }
  const InitQuery& query = keyframes_.back();
  const InitResult result =
      coarse_ ? initializer_.coarse_to_fine(*index, query, *coarse_, map_.targets())
              : initializer_.global(*index, query, map_.targets());
  if (result.status == InitResult::Status::kNeedsSubmaps) {
    map_.request_submaps(result.missing_submaps, node::wall_clock_us());
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
    global_asked_ = false;
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
  map_.tick(now_us);
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
      {"index_requests", map_.counters().index_requests},
      {"submap_requests", map_.counters().submap_requests},
      {"rejected_messages", counters_.rejected_messages + map_.counters().rejected_messages},
      {"index_keyframes",
       map_.index() ? static_cast<int64_t>(map_.index()->keyframes().size()) : 0},
      {"cached_submaps", static_cast<int64_t>(map_.cached_submaps())}};
  report.add_transport_counters(bus_);
  liloc::status_t status = bridge::to_msg(report, now_us, robot_id_);
  bus_.publish(status_channel_, status);
  last_status_us_ = now_us;
}

}  // namespace liloc
