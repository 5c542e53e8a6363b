#include "optimizer_node/optimizer_node.hpp"

#include <spdlog/spdlog.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <stdexcept>

#include "app/rate_limit.hpp"
#include "bridge/init_conversions.hpp"
#include "bridge/lcm_conversions.hpp"
#include "bridge/map_conversions.hpp"
#include "bridge/odometry_conversions.hpp"
#include "bridge/status_report.hpp"
#include "math/so3.hpp"
#include "node/convert.hpp"

namespace liloc {

void OptimizerProcessConfig::validate() const {
  if (!(status_period_s > 0 && status_period_s <= 600) || keep_keyframes < 1 ||
      lost_after_keyframes < 1 || !(reinit_sigma_xy_m > 0) || !(reinit_sigma_yaw_rad > 0) ||
      !(reinit_global_sigma_xy_m >= reinit_sigma_xy_m) || reinit_repeat_keyframes < 1 ||
      reinit_local_requests < 1) {
    throw std::invalid_argument(
        "status_period_s must be in (0, 600], keep_keyframes, lost_after_keyframes, "
        "reinit_repeat_keyframes and reinit_local_requests at least 1, the re-initialization "
        "sigmas positive, reinit_global_sigma_xy_m at least reinit_sigma_xy_m");
  }
  MapClientConfig{request_period_s, max_cached_submaps}.validate();
  localizer.validate();
  map_growth.validate();
}

OptimizerNode::OptimizerNode(transport::Transport& bus, const std::string& robot_id,
                             const OptimizerNodeConfig& config)
    : bus_(bus),
      robot_id_(robot_id),
      config_(config),
      map_(bus, robot_id, config.channels, config.descriptor,
           {config.optimizer.request_period_s, config.optimizer.max_cached_submaps},
           [this] { try_start(); }),
      growth_(config.optimizer.map_growth, robot_id),
      state_("waiting for the initializer (" +
             transport::robot_channel(robot_id, config.channels.init) + ")") {
  config_.optimizer.validate();
  const auto channel = [&](const std::string& suffix) {
    return transport::robot_channel(robot_id, suffix);
  };
  pose_channel_ = channel(config.channels.pose);
  status_channel_ = channel(config.channels.status) + ".optimizer";
  coarse_pose_channel_ = channel(config.channels.coarse_pose);
  bus_.subscribe<liloc::keyframe_t>(
      channel(config.channels.keyframe),
      [this](const liloc::keyframe_t& m, const transport::ReceiveInfo&) {
        ++counters_.keyframes;
        if (auto q = node::convert(m, bridge::init_query_from_msg, counters_.rejected_messages,
                                   "keyframe")) {
          LocalizerKeyframe kf;
          kf.id = q->keyframe_id;
          kf.utime_us = q->utime_us;
          kf.T_odom_body = q->T_odom_body;
          // A covariance that is not one (not finite, not positive definite) leaves the
          // odometry factor its configured sigmas.
          const Matrix6d covariance = bridge::covariance_from_msg(m.covariance);
          if (covariance.allFinite() && covariance.llt().info() == Eigen::Success) {
            kf.odometry_covariance = covariance;
          } else if (should_log(++counters_.keyframes_without_covariance)) {
            spdlog::warn(
                "{}: keyframe {}: its covariance is not finite and positive definite; its "
                "odometry factor takes the configured sigmas",
                robot_id_, kf.id);
          }
          kf.cloud_body = std::move(q->cloud_body);
          kf.odometry_fitness_m = std::isfinite(m.fitness) ? m.fitness : 0.0;
          on_keyframe(std::move(kf));
        }
      });
  bus_.subscribe<liloc::init_result_t>(
      channel(config.channels.init),
      [this](const liloc::init_result_t& m, const transport::ReceiveInfo&) {
        const auto from = [](const liloc::init_result_t& msg) { return bridge::from_msg(msg); };
        if (auto answer = node::convert(m, from, counters_.rejected_messages, "init result")) {
          on_init(*answer);
        }
      });
  if (config.optimizer.pose_between_keyframes) {
    bus_.subscribe<liloc::odometry_t>(
        channel(config.channels.odom),
        [this](const liloc::odometry_t& m, const transport::ReceiveInfo&) {
          const auto from = [](const liloc::odometry_t& msg) { return bridge::from_msg(msg); };
          if (auto e = node::convert(m, from, counters_.rejected_messages, "odometry")) {
            on_odometry(e->T_odom_body, e->velocity_odom, e->utime_us);
          }
        });
  }
  if (config.optimizer.localizer.graph.use_imu) {
    bus_.subscribe<liloc::imu_t>(channel(config.channels.imu),
                                 [this](const liloc::imu_t& m, const transport::ReceiveInfo&) {
                                   for (const ImuSample& s : bridge::from_msg(m)) {
                                     imu_.add(s);  // refusals are counted by the buffer
                                   }
                                 });
  }
}

void OptimizerNode::on_keyframe(LocalizerKeyframe keyframe) {
  if (!keyframes_.empty() && keyframe.utime_us <= keyframes_.back().utime_us) {
    if (should_log(++counters_.rejected_messages)) {
      spdlog::warn("{}: keyframe {} refused: its time is not after keyframe {}'s", robot_id_,
                   keyframe.id, keyframes_.back().id);
    }
    return;
  }
  if (config_.optimizer.localizer.graph.use_imu && !keyframes_.empty()) {
    const int64_t previous_us = keyframes_.back().utime_us;
    keyframe.imu = imu_.between(previous_us, keyframe.utime_us);
    imu_.drop_before(previous_us);
  }
  keyframes_.push_back(std::move(keyframe));
  while (keyframes_.size() > static_cast<size_t>(config_.optimizer.keep_keyframes)) {
    keyframes_.pop_front();
  }
  if (localizer_) {
    optimize(keyframes_.back(), true);
  } else {
    try_start();
  }
}

void OptimizerNode::on_init(const InitAnswer& answer) {
  if (!answer.localized) {
    if (!localizer_) {
      state_ = "waiting for the initializer: " + answer.message;
    }
    return;
  }
  init_ = answer;
  try_start();
}

void OptimizerNode::try_start() {
  if (!init_) {
    return;
  }
  const MapIndex* index = map_.index();
  if (index == nullptr) {
    state_ = "initialized; " + (map_.error().empty() ? map_.waiting_for_index() : map_.error());
    return;
  }
  const int64_t id = init_->keyframe_id;
  auto it = keyframes_.begin();
  while (it != keyframes_.end() && it->id != id) {
    ++it;
  }
  if (it == keyframes_.end()) {
    if (keyframes_.empty() || id > keyframes_.back().id) {
      state_ = "initialized; waiting for keyframe " + std::to_string(id);
      return;
    }
    ++counters_.inits_unmatched;
    state_ = "the initializer localized keyframe " + std::to_string(id) + ", no longer kept";
    spdlog::warn("{}: {}", robot_id_, state_);
    init_.reset();
    return;
  }
  if (localizer_) {
    // A new start: what the old graph kept of an ILM stretch goes now, unless tracking was
    // lost (then its estimates are not trusted).
    if (lost_) {
      counters_.ilm_keyframes_discarded += static_cast<int64_t>(growth_.discard());
    } else {
      send_map_update(true);
    }
  } else {
    session_id_ = robot_id_ + "-" + std::to_string(it->utime_us);
  }
  localizer_ = std::make_unique<Localizer>(config_.optimizer.localizer, *index, map_.targets());
  localizer_index_ = index;
  localizer_->start(*it, init_->T_map_body, init_->covariance);
  ++counters_.starts;
  lost_ = false;
  requests_while_lost_ = 0;
  unmatched_in_a_row_ = 0;
  scan_matched_since_start_ = 0;
  covariance_ = init_->covariance;
  state_ = "started at keyframe " + std::to_string(id) + " (" + init_->method + ")";
  spdlog::info("{}: {}", robot_id_, state_);
  init_.reset();
  publish_pose(it->utime_us, localizer_->T_map_odom() * it->T_odom_body, Eigen::Vector3d::Zero());
  upkeep_ms_ = localizer_->upkeep();
  // The keyframes that came while the initializer searched.
  for (auto next = std::next(it); next != keyframes_.end(); ++next) {
    optimize(*next, std::next(next) == keyframes_.end());
  }
}

void OptimizerNode::optimize(const LocalizerKeyframe& keyframe, bool publish) {
  if (map_.index() != localizer_index_) {
    localizer_->set_index(*map_.index());  // the map grew
    localizer_index_ = map_.index();
  }
  const LocalizerOutput out = localizer_->add(keyframe);
  ++counters_.optimized;
  if (!out.missing_submaps.empty() || !out.upcoming_submaps.empty()) {
    std::vector<int64_t> fetch = out.missing_submaps;  // the ones waited for first
    fetch.insert(fetch.end(), out.upcoming_submaps.begin(), out.upcoming_submaps.end());
    map_.request_submaps(fetch, node::wall_clock_us());
  }
  if (out.scan_matched) {
    ++counters_.scan_matched;
    ++scan_matched_since_start_;
    unmatched_in_a_row_ = 0;
  } else if (out.mode == LocalizationMode::kRelocalization && out.missing_submaps.empty()) {
    ++counters_.gated;
    ++unmatched_in_a_row_;
  } else if (out.mode == LocalizationMode::kIncremental) {
    unmatched_in_a_row_ = 0;  // outside the map nothing is expected to match
  }
  if (out.graph.covariance_ok) {
    covariance_ = out.graph.covariance;
  }
  if (out.mode == LocalizationMode::kIncremental && !lost_) {
    growth_.add(keyframe, out.T_map_body);
  }
  growth_.finalize(out.graph.finalized);
  send_map_update(false);
  last_ = out;
  const bool rlm = out.mode == LocalizationMode::kRelocalization;
  if (!lost_ && unmatched_in_a_row_ >= config_.optimizer.lost_after_keyframes) {
    declare_lost(std::to_string(unmatched_in_a_row_) +
                     " keyframes in the mapped area without a scan match (the last: " + out.gate +
                     ")",
                 out.T_map_body);
  } else if (lost_ && out.scan_matched) {
    lost_ = false;
    requests_while_lost_ = 0;
    spdlog::info("{}: tracking again at keyframe {}", robot_id_, keyframe.id);
  } else if (lost_ && ++keyframes_since_request_ >= config_.optimizer.reinit_repeat_keyframes) {
    ask_reinitialization(out.T_map_body);
  }
  if (!lost_) {
    state_ = std::string(rlm ? "RLM" : "ILM") + " at keyframe " + std::to_string(keyframe.id) +
             (out.gate.empty() ? "" : ": no scan match, " + out.gate);
  }
  if (publish) {
    publish_pose(keyframe.utime_us, out.T_map_body, out.graph.velocity_map);
  }
  upkeep_ms_ = localizer_->upkeep();
}

void OptimizerNode::declare_lost(const std::string& reason, const Eigen::Isometry3d& T_map_body) {
  lost_ = true;
  ++counters_.lost;
  lost_reason_ = reason;
  ask_reinitialization(T_map_body);
}

void OptimizerNode::ask_reinitialization(const Eigen::Isometry3d& T_map_body) {
  const bool global = scan_matched_since_start_ == 0 ||
                      requests_while_lost_ >= config_.optimizer.reinit_local_requests;
  ++requests_while_lost_;
  ++counters_.reinit_requests;
  keyframes_since_request_ = 0;
  const std::string asked =
      scan_matched_since_start_ == 0
          ? "no scan match since the start: a global re-initialization asked"
      : global ? std::to_string(config_.optimizer.reinit_local_requests) +
                     " requests around the estimate unanswered: a global re-initialization asked"
               : "re-initialization asked around the estimate";
  state_ =
      "LOST: " + lost_reason_ + "; " + asked +
      (requests_while_lost_ > 1 ? " (request " + std::to_string(requests_while_lost_) + ")" : "");
  if (should_log(requests_while_lost_)) {
    spdlog::warn("{}: {}", robot_id_, state_);
  }
  CoarsePose coarse;
  coarse.x_m = T_map_body.translation().x();
  coarse.y_m = T_map_body.translation().y();
  coarse.yaw_rad = so3::yaw(T_map_body.linear());
  coarse.sigma_xy_m =
      global ? config_.optimizer.reinit_global_sigma_xy_m : config_.optimizer.reinit_sigma_xy_m;
  coarse.sigma_yaw_rad = config_.optimizer.reinit_sigma_yaw_rad;
  liloc::pose_t msg = bridge::to_msg(coarse, node::wall_clock_us(), robot_id_);
  bus_.publish(coarse_pose_channel_, msg);
}

void OptimizerNode::send_map_update(bool flush) {
  const std::vector<MapUpdatePart> parts =
      growth_.take_update(session_id_, map_.index() ? map_.index()->version() : 0, flush);
  if (parts.empty()) {
    return;
  }
  size_t keyframes = 0;
  for (const MapUpdatePart& part : parts) {
    liloc::map_update_t msg = bridge::to_msg(part, node::wall_clock_us());
    bus_.publish(config_.channels.map_update, msg);
    keyframes += part.keyframes.size();
  }
  ++counters_.map_updates;
  counters_.ilm_keyframes_sent += static_cast<int64_t>(keyframes);
  spdlog::info("{}: map update {} with {} ILM keyframe(s) in {} message(s)", robot_id_,
               parts.front().update_id, keyframes, parts.size());
}

bool OptimizerNode::finish() {
  if (!lost_) {
    send_map_update(true);
  }
  return true;
}

void OptimizerNode::on_odometry(const Eigen::Isometry3d& T_odom_body,
                                const Eigen::Vector3d& velocity_odom, int64_t utime_us) {
  if (!localizer_) {
    return;
  }
  const Eigen::Isometry3d T_map_odom = localizer_->T_map_odom();
  publish_pose(utime_us, T_map_odom * T_odom_body, T_map_odom.linear() * velocity_odom);
}

void OptimizerNode::publish_pose(int64_t utime_us, const Eigen::Isometry3d& T_map_body,
                                 const Eigen::Vector3d& velocity_map) {
  OdometryEstimate e;
  e.utime_us = utime_us;
  e.T_odom_body = T_map_body;
  e.velocity_odom = velocity_map;
  // Between keyframes: the latest keyframe's (the odometry adds little over a keyframe's
  // spacing).
  e.covariance = covariance_;
  liloc::odometry_t msg = bridge::to_msg(e, bridge::OdometryFrames{robot_id_, "map", "body"});
  bus_.publish(pose_channel_, msg);
  ++counters_.poses;
}

void OptimizerNode::tick(int64_t now_us) {
  map_.tick(now_us);
  if (now_us - last_status_us_ >= static_cast<int64_t>(config_.optimizer.status_period_s * 1e6)) {
    publish_status(now_us);
  }
}

void OptimizerNode::publish_status(int64_t now_us) {
  bridge::StatusReport report;
  report.process = "optimizer";
  if (!localizer_) {
    report.mode = liloc::status_t::MODE_INITIALIZING;
  } else if (lost_) {
    report.mode = liloc::status_t::MODE_LOST;
  } else if (last_) {
    report.mode = last_->mode == LocalizationMode::kRelocalization ? liloc::status_t::MODE_RLM
                                                                   : liloc::status_t::MODE_ILM;
  }
  if (last_) {
    report.overlap = static_cast<float>(last_->overlap);
    report.fitness = static_cast<float>(last_->fitness_m);
    report.degenerate = last_->degenerate;
    report.timings_ms = {{"scan_match", static_cast<float>(last_->scan_match_ms)},
                         {"target", static_cast<float>(last_->target_ms)},
                         {"jfgo", static_cast<float>(last_->graph.solve_ms)},
                         {"covariance", static_cast<float>(last_->graph.covariance_ms)},
                         {"marginalization", static_cast<float>(last_->graph.marginalization_ms)},
                         {"total", static_cast<float>(last_->total_ms)},
                         {"upkeep", static_cast<float>(upkeep_ms_)}};
  }
  report.message = state_;
  report.counters = {
      {"keyframes", counters_.keyframes},
      {"optimized", counters_.optimized},
      {"scan_matched", counters_.scan_matched},
      {"gated", counters_.gated},
      {"starts", counters_.starts},
      {"inits_unmatched", counters_.inits_unmatched},
      {"lost", counters_.lost},
      {"reinit_requests", counters_.reinit_requests},
      {"poses", counters_.poses},
      {"map_updates", counters_.map_updates},
      {"ilm_keyframes_sent", counters_.ilm_keyframes_sent},
      {"ilm_keyframes_kept", static_cast<int64_t>(growth_.kept())},
      {"ilm_keyframes_discarded", counters_.ilm_keyframes_discarded},
      {"keyframes_without_covariance", counters_.keyframes_without_covariance},
      {"scan_match_factors", last_ ? last_->graph.scan_match_factors : 0},
      {"prior_nodes", last_ ? last_->graph.prior_node_count : 0},
      {"window", last_ ? last_->graph.window : 0},
      {"index_requests", map_.counters().index_requests},
      {"submap_requests", map_.counters().submap_requests},
      {"cached_submaps", static_cast<int64_t>(map_.cached_submaps())},
      {"imu_refused",
       imu_.counters().non_finite + imu_.counters().duplicate + imu_.counters().out_of_order},
      {"rejected_messages", counters_.rejected_messages + map_.counters().rejected_messages}};
  report.add_transport_counters(bus_);
  liloc::status_t status = bridge::to_msg(report, now_us, robot_id_);
  bus_.publish(status_channel_, status);
  last_status_us_ = now_us;
}

}  // namespace liloc
