#pragma once
// The common interface of the real-dataset readers (KITTI, NCLT, PCD folder): one stream
// of time-ordered sensor events, IMU samples and LiDAR sweeps merged in the order in
// which a live system would receive them. An IMU sample is available at its own time, a
// sweep when it ends (utime_us + scan_period_s), the same instants SensorStreamWriter
// stamps log events with; at equal times the IMU sample comes first, so that a consumer
// has the IMU up to the end of a sweep when the sweep arrives.
//
// Readers stream: they hold one sweep and one IMU sample ahead, never a whole file.
// Bad input throws DatasetError (file + line or byte offset); bad values inside good
// records are dropped and counted in DatasetStats instead.

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <variant>

#include "imu/imu_sample.hpp"
#include "math/trajectory.hpp"
#include "pointcloud/point_cloud.hpp"

namespace liloc::dataset {

using SensorEvent = std::variant<ImuSample, LidarScan>;

// When the event's data is complete: a sample's time, a sweep's end.
int64_t available_utime_us(const SensorEvent& event);
int64_t scan_end_utime_us(const LidarScan& scan);

// What was read and what was dropped, cumulative since the reader was opened.
struct DatasetStats {
  int64_t scans = 0;        // sweeps emitted
  int64_t points = 0;       // points in the emitted sweeps
  int64_t imu_samples = 0;  // samples emitted
  int64_t dropped_non_finite_points = 0;
  int64_t dropped_non_finite_imu_samples = 0;
  int64_t dropped_imu_samples_not_increasing = 0;    // time <= the previous sample's
  int64_t dropped_empty_scans = 0;                   // no valid point left
  int64_t dropped_scans_not_increasing = 0;          // end <= the previous sweep's end
  int64_t dropped_lidar_packets_not_increasing = 0;  // NCLT: packet time went backwards
  int64_t scans_cut_by_time = 0;  // NCLT: no azimuth wrap seen, cut at the nominal period
  // NCLT: ground-truth rows with NaN (no solution at that time) or a time not after the
  // previous row's.
  int64_t dropped_ground_truth_rows = 0;
};

// What a consumer needs to know about the sensors of a dataset.
struct SensorSetup {
  std::string sensor_model;  // lidar_scan_t.sensor_model: "hdl64", "hdl32", ...
  bool has_imu = false;
  float nominal_scan_period_s = 0.1f;
  // Pose of the lidar frame (the frame of the published points) in the body (IMU) frame,
  // when the dataset defines it.
  std::optional<Eigen::Isometry3d> T_body_lidar;
};

class SensorDatasetReader {
 public:
  virtual ~SensorDatasetReader() = default;

  // Next event in time order; false at the end of the data. Throws DatasetError.
  bool next(SensorEvent& event);

  virtual SensorSetup sensor_setup() const = 0;
  // Ground truth T_world_body (body = IMU frame, or the lidar frame for datasets without
  // an IMU), times in seconds on the same clock as the events. Empty if the dataset has
  // none. Reads the ground-truth file on each call; throws DatasetError on a bad file.
  virtual Trajectory ground_truth() = 0;
  // Fraction of the input consumed, in [0, 1]; nullopt when it cannot be known.
  virtual std::optional<double> progress() const = 0;

  const DatasetStats& stats() const { return stats_; }

 protected:
  // The two streams, each in file order; false at its end. A dataset without an IMU
  // returns false from read_imu at once.
  virtual bool read_imu(ImuSample& sample) = 0;
  virtual bool read_scan(LidarScan& scan) = 0;

  DatasetStats& mutable_stats() { return stats_; }

 private:
  // Fill the look-ahead slots with the next valid item of each stream.
  void fill_imu();
  void fill_scan();

  DatasetStats stats_;
  std::optional<ImuSample> next_imu_;
  std::optional<LidarScan> next_scan_;
  bool imu_ended_ = false;
  bool scans_ended_ = false;
  std::optional<int64_t> last_imu_utime_us_;
  std::optional<int64_t> last_scan_end_utime_us_;
};

}  // namespace liloc::dataset
