#include "ingest_node/ingest_node.hpp"

#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <stdexcept>
#include <thread>
#include <variant>

#include "app/program.hpp"
#include "math/so3.hpp"

namespace liloc {
namespace {

using Clock = std::chrono::steady_clock;

bridge::SensorStreamConfig stream_config(const dataset::SensorDatasetReader& reader,
                                         const IngestConfig& config) {
  config.validate();
  bridge::SensorStreamConfig stream;
  stream.robot_id = config.robot_id;
  stream.sensor_model = reader.sensor_setup().sensor_model;
  return stream;
}

}  // namespace

void IngestConfig::validate() const {
  if (robot_id.empty() || !(speed >= 0.0) || max_scans < 0 || !(report_period_s > 0.0)) {
    throw std::invalid_argument(
        "ingest: the robot id must not be empty, speed and max_scans must be >= 0, "
        "report_period_s positive");
  }
}

IngestNode::IngestNode(transport::Transport& bus, dataset::SensorDatasetReader& reader,
                       IngestConfig config)
    : reader_(reader),
      config_(std::move(config)),
      paced_(config_.speed > 0.0),
      writer_(bus, stream_config(reader, config_)) {}

IngestNode::IngestNode(transport::LogWriter& log, dataset::SensorDatasetReader& reader,
                       IngestConfig config)
    : reader_(reader),
      config_(std::move(config)),
      paced_(false),
      writer_(log, stream_config(reader, config_)) {}

bool IngestNode::wait_for(int64_t utime_us) const {
  const auto due =
      wall_start_ + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
                        (utime_us - *first_utime_us_) * 1e-6 / config_.speed));
  while (Clock::now() < due) {
    if (shutdown_requested()) {
      return false;
    }
    std::this_thread::sleep_for(
        std::min<Clock::duration>(due - Clock::now(), std::chrono::milliseconds(100)));
  }
  return true;
}

void IngestNode::report_progress() {
  const Clock::time_point now = Clock::now();
  if (now - last_report_ < std::chrono::duration<double>(config_.report_period_s)) {
    return;
  }
  const int64_t scans = reader_.stats().scans;
  const double rate =
      (scans - scans_at_last_report_) / std::chrono::duration<double>(now - last_report_).count();
  const std::optional<double> done =
      config_.max_scans > 0 ? std::optional<double>(static_cast<double>(scans) / config_.max_scans)
                            : reader_.progress();
  spdlog::info("{} sweeps ({:.1f}/s), {} IMU samples{}", scans, rate, reader_.stats().imu_samples,
               done ? fmt::format(", {:.1f}% done", 100.0 * *done) : std::string());
  last_report_ = now;
  scans_at_last_report_ = scans;
}

IngestSummary IngestNode::run() {
  wall_start_ = last_report_ = Clock::now();
  IngestSummary summary;
  int64_t last_utime_us = 0;
  dataset::SensorEvent event;
  while (!(summary.stopped = shutdown_requested())) {
    if (!reader_.next(event)) {
      break;
    }
    const int64_t utime_us = dataset::available_utime_us(event);
    if (!first_utime_us_) {
      first_utime_us_ = utime_us;
    }
    if (paced_ && !wait_for(utime_us)) {
      summary.stopped = true;
      break;
    }
    last_utime_us = utime_us;
    if (const auto* scan = std::get_if<LidarScan>(&event)) {
      writer_.write_scan(*scan);
    } else {
      writer_.write_imu(std::get<ImuSample>(event));
    }
    if (config_.max_scans > 0 && reader_.stats().scans >= config_.max_scans) {
      break;
    }
    report_progress();
  }
  summary.wall_s = std::chrono::duration<double>(Clock::now() - wall_start_).count();
  summary.data_s = first_utime_us_ ? (last_utime_us - *first_utime_us_) * 1e-6 : 0.0;
  const dataset::DatasetStats& stats = reader_.stats();
  spdlog::info("{}: {} sweeps ({} points), {} IMU samples, {:.2f} s of data in {:.2f} s",
               summary.stopped ? "stopped" : "done", stats.scans, stats.points, stats.imu_samples,
               summary.data_s, summary.wall_s);
  spdlog::info("dropped: {}", dropped_summary(stats));
  if (stats.scans_cut_by_time > 0) {
    spdlog::warn("{} sweeps were cut by time, not at the azimuth crossing",
                 stats.scans_cut_by_time);
  }
  return summary;
}

std::string describe(const dataset::SensorSetup& setup) {
  std::string text =
      fmt::format("sensor {}, {}, nominal sweep {:.3f} s; ", setup.sensor_model,
                  setup.has_imu ? "with IMU" : "no IMU", setup.nominal_scan_period_s);
  if (!setup.T_body_lidar) {
    return text + "T_body_lidar: not defined by this dataset, set it in the odometry config";
  }
  const Eigen::Vector3d t = setup.T_body_lidar->translation();
  const Eigen::Vector3d rotvec = so3::log(setup.T_body_lidar->linear());
  return text + fmt::format(
                    "T_body_lidar: translation [{:.4f} {:.4f} {:.4f}] m, rotation vector "
                    "[{:.5f} {:.5f} {:.5f}] rad",
                    t.x(), t.y(), t.z(), rotvec.x(), rotvec.y(), rotvec.z());
}

std::string dropped_summary(const dataset::DatasetStats& s) {
  std::string out;
  const auto add = [&](int64_t count, const char* what) {
    if (count > 0) {
      out += (out.empty() ? "" : ", ") + std::to_string(count) + " " + what;
    }
  };
  add(s.dropped_non_finite_points, "non-finite points");
  add(s.dropped_non_finite_imu_samples, "non-finite IMU samples");
  add(s.dropped_imu_samples_not_increasing, "IMU samples with non-increasing time");
  add(s.dropped_empty_scans, "empty sweeps");
  add(s.dropped_scans_not_increasing, "sweeps with non-increasing time");
  add(s.dropped_lidar_packets_not_increasing, "lidar packets with decreasing time");
  return out.empty() ? "nothing" : out;
}

}  // namespace liloc
