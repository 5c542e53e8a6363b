// liloc_ingest: reads a real dataset (KITTI odometry, NCLT, a PCD folder) and emits its IMU
// samples and LiDAR sweeps as <robot>.IMU and <robot>.LIDAR messages: into an LCM log
// (--out, as fast as the disk allows) or live onto the bus, paced by the data's clock.
//
//   liloc_ingest --format kitti --input ~/kitti/odometry --sequence 05 --out kitti05.lcmlog
//   liloc_ingest --format nclt --input ~/nclt --sequence 2012-01-15 --gt-out gt.tum
//   liloc_ingest --format folder --input ~/rec --speed 2
//
// Formats, frames and what is approximated: docs/datasets.md.

#include <spdlog/spdlog.h>

#include <memory>
#include <stdexcept>
#include <string>

#include "app/program.hpp"
#include "config/yaml_config.hpp"
#include "dataset/dataset_factory.hpp"
#include "dataset/tum_trajectory.hpp"
#include "ingest_node/ingest_node.hpp"

namespace {
using namespace liloc;

struct IngestOptions {
  std::string format, input, sequence, out_path, lcm_url, gt_out_path, config_path;
  IngestConfig node;
};

int run(const IngestOptions& options) {
  if (options.format != "kitti" && options.format != "nclt" && options.format != "folder") {
    spdlog::error("--format must be kitti, nclt or folder (got '{}')", options.format);
    return 2;
  }
  if (options.input.empty() || (!options.out_path.empty() && !options.lcm_url.empty())) {
    spdlog::error("--input is required; give one of --out (a log) and --lcm-url (live)");
    return 2;
  }
  try {
    options.node.validate();
  } catch (const std::invalid_argument& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  const dataset::DatasetReadersConfig config =
      options.config_path.empty()
          ? dataset::DatasetReadersConfig{}
          : load_config<dataset::DatasetReadersConfig>(options.config_path, "ingest");
  const std::unique_ptr<dataset::SensorDatasetReader> reader =
      dataset::open_dataset(options.format, options.input, options.sequence, config);
  spdlog::info("{}", describe(reader->sensor_setup()));
  if (!options.gt_out_path.empty()) {
    const Trajectory ground_truth = reader->ground_truth();
    if (ground_truth.empty()) {
      spdlog::error("--gt-out: this dataset has no ground truth");
      return 1;
    }
    write_tum(options.gt_out_path, ground_truth);
    const int64_t skipped = reader->stats().dropped_ground_truth_rows;
    spdlog::info("wrote {} ground-truth poses (T_world_body) to {}{}", ground_truth.size(),
                 options.gt_out_path,
                 skipped > 0 ? " (" + std::to_string(skipped) + " rows without a solution skipped)"
                             : std::string());
  }
  if (!options.out_path.empty()) {
    transport::LogWriter log(options.out_path);
    spdlog::info("writing {} as {}", options.out_path, options.node.robot_id);
    IngestNode(log, *reader, options.node).run();
    return 0;
  }
  transport::TransportConfig transport_config;
  if (!options.lcm_url.empty()) {
    transport_config.url = options.lcm_url;
  }
  transport::Transport bus(transport_config);
  spdlog::info("publishing on {} as {} (speed {})", transport_config.url, options.node.robot_id,
               options.node.speed);
  IngestNode(bus, *reader, options.node).run();
  if (bus.publish_errors() > 0) {
    spdlog::warn("{} messages could not be published", bus.publish_errors());
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
  cli.add_option("robot", &options.node.robot_id, "robot id, the prefix of the channels");
  cli.add_option("out", &options.out_path, "write this LCM log instead of publishing live");
  cli.add_option("lcm-url", &options.lcm_url,
                 "LCM provider to publish on (default: the TransportConfig udpm URL)");
  cli.add_option("speed", &options.node.speed,
                 "live playback speed factor; 0 = as fast as possible");
  cli.add_option("gt-out", &options.gt_out_path, "also write the ground truth as a TUM file");
  cli.add_option("max-scans", &options.node.max_scans, "stop after this many sweeps; 0 = all");
  cli.add_option("config", &options.config_path,
                 "YAML file whose 'ingest' section sets reader options (kitti, nclt, folder)");
  return run_program(cli, "ingest", argc, argv, [&] { return run(options); });
}
