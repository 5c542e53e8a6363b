#include "odometry_node/odometry_node.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>

#include "app/rate_limit.hpp"
#include "bridge/lcm_conversions.hpp"
#include "bridge/status_report.hpp"

namespace liloc {

OdometryNode::OdometryNode(transport::Transport& bus, const std::string& robot_id,
                           const OdometryNodeConfig& config)
    : bus_(bus),
      robot_id_(robot_id),
      config_(config),
      odometry_(std::make_unique<LidarInertialOdometry>(config.odometry)),
      frames_{robot_id, "odom", "body"},
      imu_clock_(config.sensors.max_time_jump_s, config.sensors.confirm_jump_messages),
      lidar_clock_(config.sensors.max_time_jump_s, config.sensors.confirm_jump_messages) {
  config_.sensors.validate();
  const auto channel = [&](const std::string& suffix) {
    return transport::robot_channel(robot_id, suffix);
  };
  imu_channel_ = channel(config.channels.imu);
  lidar_channel_ = channel(config.channels.lidar);
  odom_channel_ = channel(config.channels.odom);
  keyframe_channel_ = channel(config.channels.keyframe);
  status_channel_ = channel(config.channels.status) + ".odometry";
  bus_.subscribe<liloc::imu_t>(
      imu_channel_, [this](const liloc::imu_t& msg, const transport::ReceiveInfo&) {
        size_t non_finite = 0;
        const std::vector<ImuSample> samples = bridge::from_msg(msg, &non_finite);
        on_imu(samples, non_finite);
      });
  bus_.subscribe<liloc::lidar_scan_t>(
      lidar_channel_, [this](const liloc::lidar_scan_t& msg, const transport::ReceiveInfo&) {
        size_t non_finite = 0;
        LidarScan scan = bridge::from_msg(msg, &non_finite);
        on_scan(std::move(scan), non_finite);
      });
  bus_.subscribe<liloc::correction_t>(
      channel(config.channels.correction),
      [this](const liloc::correction_t& msg, const transport::ReceiveInfo&) {
        odometry_->add_correction(bridge::from_msg(msg));
      });
  spdlog::info("odometry for {} ({})", robot_id,
               config.odometry.use_imu ? "LiDAR-inertial" : "LiDAR only");
}

void OdometryNode::on_imu(const std::vector<ImuSample>& samples, size_t non_finite) {
  for (const ImuSample& s : samples) {
    ++imu_received_;
    if (const std::optional<std::string> why = implausible_imu(s, config_.sensors)) {
      reject("imu_implausible", "IMU sample refused: " + *why);
      continue;
    }
    const StreamClock::Verdict time = imu_clock_.check(s.utime_us);
    if (time == StreamClock::Verdict::kJump) {
      reject("imu_time_jump", "IMU sample refused: time " + std::to_string(s.utime_us) +
                                  " us jumps from the stream's");
      continue;
    }
    if (time == StreamClock::Verdict::kNewTimeline) {
      restart("the IMU's time moved to " + std::to_string(s.utime_us) + " us");
    }
    odometry_->add_imu(s);
    last_data_utime_us_ = std::max(last_data_utime_us_, s.utime_us);
  }
  non_finite_imu_ += static_cast<int64_t>(non_finite);
  publish(odometry_->process());
}

void OdometryNode::on_scan(LidarScan scan, size_t non_finite) {
  ++scans_received_;
  non_finite_points_ += static_cast<int64_t>(non_finite);
  if (const std::optional<std::string> why = implausible_scan(scan, config_.sensors)) {
    reject("scan_implausible", "sweep refused: " + *why);
    return;
  }
  const StreamClock::Verdict time = lidar_clock_.check(scan.utime_us);
  if (time == StreamClock::Verdict::kJump) {
    reject("scan_time_jump",
           "sweep refused: time " + std::to_string(scan.utime_us) + " us jumps from the stream's");
    return;
  }
  if (time == StreamClock::Verdict::kNewTimeline) {
    restart("the LiDAR's time moved to " + std::to_string(scan.utime_us) + " us");
  } else if (last_scan_start_us_ != 0 &&
             std::llabs(scan.utime_us - last_scan_start_us_) <
                 static_cast<int64_t>(config_.sensors.min_scan_interval_s * 1e6)) {
    reject("scan_too_soon", "sweep refused: it starts " +
                                std::to_string(scan.utime_us - last_scan_start_us_) +
                                " us after the previous one");
    return;
  }
  last_scan_start_us_ = scan.utime_us;
  last_data_utime_us_ = std::max(last_data_utime_us_, scan.utime_us);
  odometry_->add_scan(std::move(scan));
  publish(odometry_->process());
}

void OdometryNode::reject(const std::string& kind, const std::string& reason) {
  const int64_t count = ++rejected_[kind];
  ++rejected_total_;
  last_problem_ = reason;
  if (should_log(count)) {
    spdlog::warn("{}: {} ({} {} so far)", robot_id_, reason, count, kind);
  }
}

void OdometryNode::restart(const std::string& why) {
  ++restarts_;
  last_problem_ = why + ": the odometry restarted (its odom frame starts again)";
  spdlog::warn("{}: {}", robot_id_, last_problem_);
  odometry_ = std::make_unique<LidarInertialOdometry>(config_.odometry);
  last_scan_start_us_ = 0;
}

void OdometryNode::tick(int64_t now_us) {
  if (now_us - last_status_wall_us_ >= static_cast<int64_t>(config_.status_period_s * 1e6)) {
    publish_status(nullptr, last_data_utime_us_ > 0 ? last_data_utime_us_ : now_us);
  }
}

bool OdometryNode::finish() {
  publish(odometry_->flush());
  const OdometryCounters& c = odometry_->counters();
  spdlog::info(
      "done: {} sweeps processed ({} received, {} out of order, {} too small, {} "
      "before init, {} without IMU, {} failed), {} keyframes, {} degenerate, {} searched after "
      "a pause ({} around a second guess), {} lost ({} local-map restarts, {} health resets, "
      "{} found again), {} contradicting the IMU, {} fitting worse deskewed again, {} fitting "
      "far worse searched again ({} moved), {} after a pause along their own twist, {} placed "
      "in a young local map; {} "
      "messages refused at the door, {} restarts",
      c.scans_processed, c.scans_received, c.scans_out_of_order, c.scans_too_small,
      c.scans_before_init, c.scans_without_imu, c.scans_failed, c.keyframes, c.degenerate_scans,
      c.searched_scans, c.second_guesses, c.lost_scans, c.map_restarts, c.health_resets,
      c.reanchors, c.imu_disagreements, c.poor_fits_deskewed, c.poor_fits_searched,
      c.poor_fits_moved, c.own_twists_after_gaps, c.young_map_searches_accepted, rejected_total_,
      restarts_);
  if (!extrinsic_check_.empty()) {
    spdlog::info("{}", extrinsic_check_);
  }
  return true;
}

void OdometryNode::publish(const std::vector<OdometryEstimate>& estimates) {
  for (const OdometryEstimate& e : estimates) {
    liloc::odometry_t odom = bridge::to_msg(e, frames_);
    bus_.publish(odom_channel_, odom);
    if (e.keyframe) {
      liloc::keyframe_t kf = bridge::to_msg(*e.keyframe, frames_);
      bus_.publish(keyframe_channel_, kf);
    }
    if (!e.lost_reason.empty()) {
      last_problem_ = e.lost_reason;
      const int64_t lost = odometry_->counters().lost_scans;
      if (should_log(lost)) {  // the summary has the count
        spdlog::warn("lost ({} sweeps so far): {}", lost, e.lost_reason);
      }
    }
    if (!e.imu_disagreement.empty()) {
      last_problem_ = e.imu_disagreement;
      if (should_log(odometry_->counters().imu_disagreements)) {
        spdlog::warn("{} ({} sweeps so far)", e.imu_disagreement,
                     odometry_->counters().imu_disagreements);
      }
    }
    if (!e.reanchored.empty()) {
      // Rare (a restart before it) and a jump of the output: always said.
      spdlog::warn("{}: {}", robot_id_, e.reanchored);
    }
    if (!e.ring_adaptation.empty()) {
      spdlog::info("{}: {}", robot_id_, e.ring_adaptation);
    }
    if (e.extrinsic_check) {
      extrinsic_check_ = e.extrinsic_check->message;
      extrinsic_warned_ = e.extrinsic_check->warn;
      if (e.extrinsic_check->warn) {
        last_problem_ = extrinsic_check_;
        spdlog::warn("{}", extrinsic_check_);
      } else {
        spdlog::info("{}", extrinsic_check_);
      }
    }
    publish_status(&e, e.utime_us);
  }
  if (!odometry_->last_failure().empty()) {
    last_problem_ = "sweep dropped: " + odometry_->last_failure();
  }
}

std::string OdometryNode::waiting_reason() const {
  if (scans_received_ == 0) {
    return "waiting for LiDAR on " + lidar_channel_;
  }
  if (config_.odometry.use_imu && !odometry_->has_imu()) {
    return "waiting for IMU on " + imu_channel_;
  }
  if (odometry_->queued_scans() > 0) {
    return std::to_string(odometry_->queued_scans()) +
           " sweep(s) waiting for the IMU to cover them (" + imu_channel_ + ")";
  }
  return "no sweep since the last status";
}

void OdometryNode::publish_status(const OdometryEstimate* e, int64_t utime_us) {
  bridge::StatusReport report;
  report.process = "odometry";
  if (e != nullptr) {
    report.fitness = static_cast<float>(e->fitness_m);
    report.degenerate = e->degenerate;
    report.min_eigenvalue =
        static_cast<float>(std::min(e->translation_eigen_ratio, e->rotation_eigen_ratio));
    report.timings_ms = {
        {"preprocess", e->timings.preprocess_ms}, {"propagate", e->timings.propagate_ms},
        {"register", e->timings.register_ms},     {"map", e->timings.map_ms},
        {"keyframe", e->timings.keyframe_ms},     {"total", e->timings.total_ms}};
  }
  const OdometryCounters& c = odometry_->counters();
  report.counters = {{"scans_received", c.scans_received},
                     {"scans_processed", c.scans_processed},
                     {"scans_out_of_order", c.scans_out_of_order},
                     {"scans_too_small", c.scans_too_small},
                     {"scans_before_init", c.scans_before_init},
                     {"scans_without_imu", c.scans_without_imu},
                     {"scans_dropped_queue", c.scans_dropped_queue},
                     {"scans_failed", c.scans_failed},
                     {"imu_gaps", c.imu_gaps},
                     {"imu_rejected", c.imu_rejected},
                     {"imu_dropped_old", c.imu_dropped_old},
                     {"non_finite_imu", non_finite_imu_},
                     {"non_finite_points", non_finite_points_},
                     {"degenerate_scans", c.degenerate_scans},
                     {"searched_scans", c.searched_scans},
                     {"second_guesses", c.second_guesses},
                     {"map_restarts", c.map_restarts},
                     {"health_resets", c.health_resets},
                     {"imu_disagreements", c.imu_disagreements},
                     {"poor_fits_searched", c.poor_fits_searched},
                     {"poor_fits_moved", c.poor_fits_moved},
                     {"poor_fits_deskewed", c.poor_fits_deskewed},
                     {"own_twists_after_gaps", c.own_twists_after_gaps},
                     {"young_map_searches_accepted", c.young_map_searches_accepted},
                     {"reanchors", c.reanchors},
                     {"lost_scans", c.lost_scans},
                     {"standstill_scans", c.standstill_scans},
                     {"keyframes", c.keyframes},
                     {"corrections_applied", c.corrections_applied},
                     {"corrections_rejected", c.corrections_rejected},
                     {"restarts", restarts_},
                     {"map_points", static_cast<int64_t>(odometry_->map_points())}};
  for (const auto& [kind, count] : rejected_) {
    report.counters.emplace_back("rejected_" + kind, count);
  }
  report.add_transport_counters(bus_);
  if (e == nullptr) {
    report.mode =
        c.scans_processed == 0 ? liloc::status_t::MODE_INITIALIZING : liloc::status_t::MODE_NONE;
    report.message = waiting_reason();
    if (!last_problem_.empty()) {
      report.message += "; last problem: " + last_problem_;
    }
  } else if (!e->lost_reason.empty()) {
    report.mode = liloc::status_t::MODE_LOST;
    report.message = e->lost_reason;
  } else if (!e->reanchored.empty()) {
    report.message = e->reanchored;
  } else if (!e->imu_disagreement.empty()) {
    report.message = e->imu_disagreement;
  } else if (!e->registered) {
    report.message = "sweep too small to register: pose from the motion model";
  } else if (e->degenerate) {
    report.message = "registration degenerate: the motion model holds the weak direction";
  } else if (extrinsic_warned_) {
    report.message = extrinsic_check_;  // until the configuration is fixed
  }
  liloc::status_t status = bridge::to_msg(report, utime_us, frames_.robot_id);
  bus_.publish(status_channel_, status);
  last_status_wall_us_ = node::wall_clock_us();
}

}  // namespace liloc
