#pragma once
// The ingest process's node: a real dataset's sensor events (KITTI, NCLT, a PCD folder)
// written as <robot>.IMU and <robot>.LIDAR messages, live onto a Transport paced by the
// data's clock, or into an LCM log as fast as the disk allows.

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

#include "bridge/sensor_stream.hpp"
#include "dataset/sensor_dataset_reader.hpp"
#include "transport/log_file.hpp"
#include "transport/transport.hpp"

namespace liloc {

struct IngestConfig {
  std::string robot_id = "robot0";
  double speed = 1.0;            // live: the data's clock scaled by this; 0 = as fast as possible
  int max_scans = 0;             // stop after this many sweeps; 0 = all
  double report_period_s = 2.0;  // progress in the log
  void validate() const;
};

struct IngestSummary {
  bool stopped = false;  // by a shutdown request, before the end of the data
  double data_s = 0.0;   // of data written
  double wall_s = 0.0;
};

class IngestNode {
 public:
  // Live onto `bus`, paced.
  IngestNode(transport::Transport& bus, dataset::SensorDatasetReader& reader, IngestConfig config);
  // Into `log`, unpaced.
  IngestNode(transport::LogWriter& log, dataset::SensorDatasetReader& reader, IngestConfig config);

  // Writes events until the data ends, max_scans is reached or a shutdown is requested;
  // logs what was written and what the reader dropped.
  IngestSummary run();

 private:
  // Sleeps until the data clock, scaled by speed, reaches utime_us; false if a shutdown was
  // requested meanwhile.
  bool wait_for(int64_t utime_us) const;
  void report_progress();

  dataset::SensorDatasetReader& reader_;
  IngestConfig config_;
  bool paced_;
  bridge::SensorStreamWriter writer_;
  std::chrono::steady_clock::time_point wall_start_, last_report_;
  int64_t scans_at_last_report_ = 0;
  std::optional<int64_t> first_utime_us_;
};

// The sensors of a dataset, and what its reader dropped, for the log.
std::string describe(const dataset::SensorSetup& setup);
std::string dropped_summary(const dataset::DatasetStats& stats);

}  // namespace liloc
