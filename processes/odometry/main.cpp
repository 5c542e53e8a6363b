// liloc_odometry: LiDAR-inertial odometry for one robot.
//   in:  <robot>.IMU, <robot>.LIDAR, <robot>.CORRECTION
//   out: <robot>.ODOM (every sweep), <robot>.KEYFRAME, <robot>.STATUS.odometry

#include <spdlog/spdlog.h>

#include "app/program.hpp"
#include "bridge/lcm_conversions.hpp"
#include "bridge/odometry_conversions.hpp"
#include "bridge/status_report.hpp"
#include "config/yaml_config.hpp"
#include "system/system_config.hpp"

namespace {
using namespace liloc;

class OdometryProcess {
 public:
  OdometryProcess(const SystemConfig& config, const std::string& robot_id)
      : config_(config),
        bus_(config.transport),
        odometry_(config.odometry),
        frames_{robot_id, "odom", "body"} {
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
  }

  // Runs until Ctrl-C or the end of a file:// log.
  void run() {
    spdlog::info("odometry for {} on {} ({})", frames_.robot_id, config_.transport.url,
                 config_.odometry.use_imu ? "LiDAR-inertial" : "LiDAR only");
    while (!shutdown_requested()) {
      if (bus_.handle(100) < 0) {
        break;
      }
    }
    publish(odometry_.flush());
    const OdometryCounters& c = odometry_.counters();
    spdlog::info(
        "done: {} sweeps processed ({} received, {} out of order, {} too small, {} "
        "before init, {} without IMU), {} keyframes, {} degenerate",
        c.scans_processed, c.scans_received, c.scans_out_of_order, c.scans_too_small,
        c.scans_before_init, c.scans_without_imu, c.keyframes, c.degenerate_scans);
  }

 private:
  void publish(const std::vector<OdometryEstimate>& estimates) {
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

  void publish_status(const OdometryEstimate& e) {
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

  SystemConfig config_;
  transport::Transport bus_;
  LidarInertialOdometry odometry_;
  bridge::OdometryFrames frames_;
  std::string odom_channel_, keyframe_channel_, status_channel_;
  int64_t non_finite_imu_ = 0;
  int64_t non_finite_points_ = 0;
};
}  // namespace

int main(int argc, char** argv) {
  std::string config_path = "config/liloc.yaml";
  std::string robot_id = "robot0";
  std::string url;
  std::string publish_url;
  bool print_config = false;
  CommandLine cli("liloc_odometry", "LiDAR-inertial odometry (the ILM front end) for one robot.");
  cli.add_option("config", &config_path, "system config (YAML)");
  cli.add_option("robot", &robot_id, "robot id: the prefix of its channels");
  cli.add_option("lcm-url", &url,
                 "LCM URL, overrides the config (file:///x.lcmlog?speed=0 "
                 "replays a log)");
  cli.add_option("publish-url", &publish_url,
                 "publish here instead (file:///out.lcmlog?mode=w writes a log)");
  cli.add_flag("print-config", &print_config, "print the effective config and exit");
  return run_program(cli, "odometry", argc, argv, [&]() -> int {
    SystemConfig config = load_config<SystemConfig>(config_path);
    if (!url.empty()) {
      config.transport.url = url;
    }
    if (!publish_url.empty()) {
      config.transport.publish_url = publish_url;
    }
    if (print_config) {
      std::printf("%s\n", dump_config(config).c_str());
      return 0;
    }
    OdometryProcess process(config, robot_id);
    process.run();
    return 0;
  });
}
