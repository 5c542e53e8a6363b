// liloc_ingest: reads a real dataset (KITTI odometry, NCLT, a PCD folder) and emits its IMU
// samples and LiDAR sweeps as <robot>.IMU and <robot>.LIDAR messages: into an LCM log
// (--out, as fast as the disk allows) or live onto the bus, paced by the data's clock.
//
//   liloc_ingest --format kitti --input ~/kitti/odometry --sequence 05 --out kitti05.lcmlog
//   liloc_ingest --format nclt --input ~/nclt --sequence 2012-01-15 --gt-out gt.tum
//   liloc_ingest --format folder --input ~/rec --speed 2
//
// Formats, frames and what is approximated: docs/datasets.md.

#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <variant>

#include "app/program.hpp"
#include "bridge/sensor_stream.hpp"
#include "config/yaml_config.hpp"
#include "dataset/dataset_factory.hpp"
#include "dataset/tum_trajectory.hpp"
#include "math/so3.hpp"

namespace {
using namespace liloc;
using Clock = std::chrono::steady_clock;

struct IngestOptions {
  std::string format;
  std::string input;
  std::string sequence;
  std::string robot_id = "robot0";
  std::string out_path;
  std::string lcm_url;
  double speed = 1.0;
  std::string gt_out_path;
  int max_scans = 0;
  std::string config_path;
};

void log_setup(const dataset::SensorSetup& setup) {
  spdlog::info("sensor {}, {}, nominal sweep {:.3f} s", setup.sensor_model,
               setup.has_imu ? "with IMU" : "no IMU", setup.nominal_scan_period_s);
  if (setup.T_body_lidar) {
    const Eigen::Vector3d t = setup.T_body_lidar->translation();
    const Eigen::Vector3d rotvec = so3::log(setup.T_body_lidar->linear());
    spdlog::info(
        "T_body_lidar: translation [{:.4f} {:.4f} {:.4f}] m, rotation vector "
        "[{:.5f} {:.5f} {:.5f}] rad",
        t.x(), t.y(), t.z(), rotvec.x(), rotvec.y(), rotvec.z());
  } else {
    spdlog::info("T_body_lidar: not defined by this dataset, set it in the odometry config");
  }
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

// Sleeps until the data clock, scaled by speed, reaches event_utime_us; false if a
// shutdown was requested while waiting.
bool wait_for(int64_t event_utime_us, int64_t first_utime_us, Clock::time_point wall_start,
              double speed) {
  const auto due =
      wall_start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
                       (event_utime_us - first_utime_us) * 1e-6 / speed));
  while (Clock::now() < due) {
    if (shutdown_requested()) {
      return false;
    }
    std::this_thread::sleep_for(
        std::min<Clock::duration>(due - Clock::now(), std::chrono::milliseconds(100)));
  }
  return true;
}

int run(const IngestOptions& options) {
  if (options.format != "kitti" && options.format != "nclt" && options.format != "folder") {
    spdlog::error("--format must be kitti, nclt or folder (got '{}')", options.format);
    return 2;
  }
  if (options.input.empty()) {
    spdlog::error("--input is required");
    return 2;
  }
  if (!options.out_path.empty() && !options.lcm_url.empty()) {
    spdlog::error("--out writes a log, --lcm-url publishes live: give one of them");
    return 2;
  }
  if (!(options.speed >= 0.0) || options.max_scans < 0) {
    spdlog::error("--speed and --max-scans must be >= 0");
    return 2;
  }
  const dataset::DatasetReadersConfig config =
      options.config_path.empty()
          ? dataset::DatasetReadersConfig{}
          : load_config<dataset::DatasetReadersConfig>(options.config_path, "ingest");
  std::unique_ptr<dataset::SensorDatasetReader> reader =
      dataset::open_dataset(options.format, options.input, options.sequence, config);
  const dataset::SensorSetup setup = reader->sensor_setup();
  log_setup(setup);

  if (!options.gt_out_path.empty()) {
    const Trajectory ground_truth = reader->ground_truth();
    if (ground_truth.empty()) {
      spdlog::error("--gt-out: this dataset has no ground truth");
      return 1;
    }
    write_tum(options.gt_out_path, ground_truth);
    spdlog::info("wrote {} ground-truth poses (T_world_body) to {}{}", ground_truth.size(),
                 options.gt_out_path,
                 reader->stats().dropped_ground_truth_rows > 0
                     ? " (" + std::to_string(reader->stats().dropped_ground_truth_rows) +
                           " rows without a solution skipped)"
                     : std::string());
  }

  bridge::SensorStreamConfig stream_config;
  stream_config.robot_id = options.robot_id;
  stream_config.sensor_model = setup.sensor_model;
  std::unique_ptr<transport::LogWriter> log;
  std::unique_ptr<transport::Transport> bus;
  std::unique_ptr<bridge::SensorStreamWriter> writer;
  const bool live = options.out_path.empty();
  if (live) {
    transport::TransportConfig transport_config;
    if (!options.lcm_url.empty()) {
      transport_config.url = options.lcm_url;
    }
    bus = std::make_unique<transport::Transport>(transport_config);
    writer = std::make_unique<bridge::SensorStreamWriter>(*bus, stream_config);
    spdlog::info("publishing on {} as {} (speed {})", transport_config.url, options.robot_id,
                 options.speed);
  } else {
    log = std::make_unique<transport::LogWriter>(options.out_path);
    writer = std::make_unique<bridge::SensorStreamWriter>(*log, stream_config);
    spdlog::info("writing {} as {}", options.out_path, options.robot_id);
  }

  const Clock::time_point wall_start = Clock::now();
  Clock::time_point last_report = wall_start;
  int64_t scans_at_last_report = 0;
  std::optional<int64_t> first_utime_us;
  int64_t last_utime_us = 0;
  dataset::SensorEvent event;
  while (!shutdown_requested() && reader->next(event)) {
    const int64_t utime_us = dataset::available_utime_us(event);
    if (!first_utime_us) {
      first_utime_us = utime_us;
    }
    if (live && options.speed > 0 &&
        !wait_for(utime_us, *first_utime_us, wall_start, options.speed)) {
      break;
    }
    last_utime_us = utime_us;
    if (const auto* scan = std::get_if<LidarScan>(&event)) {
      writer->write_scan(*scan);
    } else {
      writer->write_imu(std::get<ImuSample>(event));
    }
    const int64_t scans = reader->stats().scans;
    if (options.max_scans > 0 && scans >= options.max_scans) {
      break;
    }
    const Clock::time_point now = Clock::now();
    if (now - last_report >= std::chrono::seconds(2)) {
      const double rate =
          (scans - scans_at_last_report) / std::chrono::duration<double>(now - last_report).count();
      const std::optional<double> done =
          options.max_scans > 0
              ? std::optional<double>(static_cast<double>(scans) / options.max_scans)
              : reader->progress();
      spdlog::info("{} sweeps ({:.1f}/s), {} IMU samples{}", scans, rate,
                   reader->stats().imu_samples,
                   done ? fmt::format(", {:.1f}% done", 100.0 * *done) : std::string());
      last_report = now;
      scans_at_last_report = scans;
    }
  }

  const dataset::DatasetStats& stats = reader->stats();
  const double wall_s = std::chrono::duration<double>(Clock::now() - wall_start).count();
  const double data_s = first_utime_us ? (last_utime_us - *first_utime_us) * 1e-6 : 0.0;
  spdlog::info("{}: {} sweeps ({} points), {} IMU samples, {:.2f} s of data in {:.2f} s",
               shutdown_requested() ? "stopped" : "done", stats.scans, stats.points,
               stats.imu_samples, data_s, wall_s);
  spdlog::info("dropped: {}", dropped_summary(stats));
  if (stats.scans_cut_by_time > 0) {
    spdlog::warn("{} sweeps were cut by time, not at the azimuth crossing",
                 stats.scans_cut_by_time);
  }
  if (bus && bus->publish_errors() > 0) {
    spdlog::warn("{} messages could not be published", bus->publish_errors());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  IngestOptions options;
  CommandLine cli("liloc_ingest",
                  "Reads a KITTI odometry, NCLT or PCD-folder dataset and writes its IMU samples "
                  "and LiDAR sweeps as <robot>.IMU / <robot>.LIDAR messages to an LCM log or "
                  "the live bus. See docs/datasets.md.");
  cli.add_option("format", &options.format, "kitti, nclt or folder");
  cli.add_option("input", &options.input,
                 "KITTI: the folder holding sequences/; NCLT: the session folder (or the "
                 "folder of sessions with --sequence); folder: the dataset folder");
  cli.add_option("sequence", &options.sequence,
                 "KITTI sequence (default 00); NCLT session date under --input");
  cli.add_option("robot", &options.robot_id, "robot id, the prefix of the channels");
  cli.add_option("out", &options.out_path, "write this LCM log instead of publishing live");
  cli.add_option("lcm-url", &options.lcm_url,
                 "LCM provider to publish on (default: the TransportConfig udpm URL)");
  cli.add_option("speed", &options.speed, "live playback speed factor; 0 = as fast as possible");
  cli.add_option("gt-out", &options.gt_out_path, "also write the ground truth as a TUM file");
  cli.add_option("max-scans", &options.max_scans, "stop after this many sweeps; 0 = all");
  cli.add_option("config", &options.config_path,
                 "YAML file whose 'ingest' section sets reader options (kitti, nclt, folder)");
  return run_program(cli, "ingest", argc, argv, [&] { return run(options); });
}
