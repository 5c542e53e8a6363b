#include "odometry_node/odometry_node.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>

#include "bridge/lcm_conversions.hpp"
#include "bridge/status_report.hpp"

namespace liloc {

OdometryNode::OdometryNode(transport::Transport& bus, const std::string& robot_id,
                           const OdometryNodeConfig& config)
    : bus_(bus), config_(config), odometry_(config.odometry), frames_{robot_id, "odom", "body"} {
  const auto channel = [&](const std::string& suffix) {
    return transport::robot_channel(robot_id, suffix);
  };
  odom_channel_ = channel(config.channels.odom);
  keyframe_channel_ = channel(config.channels.keyframe);
  status_channel_ = channel(config.channels.status) + ".odometry";
  bus_.subscribe<liloc::imu_t>(channel(config.channels.imu),
                               [this](const liloc::imu_t& msg, const transport::ReceiveInfo&) {
                                 size_t non_finite = 0;
                                 for (const ImuSample& s : bridge::from_msg(msg, &non_finite)) {
                                   odometry_.add_imu(s);
                                 }
                                 non_finite_imu_ += static_cast<int64_t>(non_finite);
                                 publish(odometry_.process());
                               });
  bus_.subscribe<liloc::lidar_scan_t>(
      channel(config.channels.lidar),
      [this](const liloc::lidar_scan_t& msg, const transport::ReceiveInfo&) {
        size_t non_finite = 0;
        odometry_.add_scan(bridge::from_msg(msg, &non_finite));
        non_finite_points_ += static_cast<int64_t>(non_finite);
        publish(odometry_.process());
      });
  bus_.subscribe<liloc::correction_t>(
      channel(config.channels.correction),
      [this](const liloc::correction_t& msg, const transport::ReceiveInfo&) {
        odometry_.add_correction(bridge::from_msg(msg));
      });
  spdlog::info("odometry for {} ({})", robot_id,
               config.odometry.use_imu ? "LiDAR-inertial" : "LiDAR only");
}

bool OdometryNode::finish() {
  publish(odometry_.flush());
  const OdometryCounters& c = odometry_.counters();
  spdlog::info(
      "done: {} sweeps processed ({} received, {} out of order, {} too small, {} "
      "before init, {} without IMU), {} keyframes, {} degenerate",
      c.scans_processed, c.scans_received, c.scans_out_of_order, c.scans_too_small,
      c.scans_before_init, c.scans_without_imu, c.keyframes, c.degenerate_scans);
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
    publish_status(e);
  }
}

void OdometryNode::publish_status(const OdometryEstimate& e) {
  bridge::StatusReport report;
  report.process = "odometry";
  report.fitness = static_cast<float>(e.fitness_m);
  report.degenerate = e.degenerate;
  report.min_eigenvalue =
      static_cast<float>(std::min(e.translation_eigen_ratio, e.rotation_eigen_ratio));
  report.timings_ms = {
      {"preprocess", e.timings.preprocess_ms}, {"propagate", e.timings.propagate_ms},
      {"register", e.timings.register_ms},     {"map", e.timings.map_ms},
      {"keyframe", e.timings.keyframe_ms},     {"total", e.timings.total_ms}};
  const OdometryCounters& c = odometry_.counters();
  report.counters = {{"scans_received", c.scans_received},
                     {"scans_processed", c.scans_processed},
                     {"scans_out_of_order", c.scans_out_of_order},
                     {"scans_too_small", c.scans_too_small},
                     {"scans_before_init", c.scans_before_init},
                     {"scans_without_imu", c.scans_without_imu},
                     {"imu_gaps", c.imu_gaps},
                     {"imu_rejected", c.imu_rejected},
                     {"non_finite_imu", non_finite_imu_},
                     {"non_finite_points", non_finite_points_},
                     {"degenerate_scans", c.degenerate_scans},
                     {"standstill_scans", c.standstill_scans},
                     {"keyframes", c.keyframes},
                     {"corrections_applied", c.corrections_applied},
                     {"corrections_rejected", c.corrections_rejected},
                     {"map_points", static_cast<int64_t>(odometry_.map_points())}};
  report.add_transport_counters(bus_);
  if (!e.registered) {
    report.message = "sweep too small to register: pose from the motion model";
  } else if (e.degenerate) {
    report.message = "registration degenerate: the motion model holds the weak direction";
  }
  liloc::status_t status = bridge::to_msg(report, e.utime_us, frames_.robot_id);
  bus_.publish(status_channel_, status);
}

}  // namespace liloc
