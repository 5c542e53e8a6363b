#pragma once
// A generic dataset folder, for recordings converted from any source:
//   <folder>/scans/<time>.pcd     one sweep per file; <time> in seconds ("1700000000.1")
//                                 or, from 1e12 on, in nanoseconds ("1700000000100000000");
//                                 fields as pcd_scan_reader.hpp reads them
//   <folder>/imu.csv              optional: header "time_s,ax,ay,az,gx,gy,gz", then one
//                                 sample per line (s, m/s^2, rad/s, in the IMU frame)
//   <folder>/ground_truth.tum     optional: T_world_body, body = IMU frame
// A time in the file name is the sweep's start unless the points carry absolute times.
// The points are published in the frame they are stored in; the folder does not say
// where that frame sits on the body, so sensor_setup() has no T_body_lidar.

#include <memory>
#include <string>
#include <vector>

#include "dataset/sensor_dataset_reader.hpp"
#include "dataset/text_line_reader.hpp"

namespace liloc::dataset {

struct FolderDatasetConfig {
  double scan_period_s = 0.1;            // nominal, when point times span less
  std::string sensor_model = "unknown";  // lidar_scan_t.sensor_model

  template <class V>
  void visit_fields(V& v) {
    v("scan_period_s", scan_period_s);
    v("sensor_model", sensor_model);
  }
  void validate() const;
};

class FolderDatasetReader : public SensorDatasetReader {
 public:
  // Lists scans/ and checks imu.csv's header; throws DatasetError if scans/ is missing,
  // a file name is not a time, or the header differs.
  explicit FolderDatasetReader(const std::string& folder, FolderDatasetConfig config = {});

  SensorSetup sensor_setup() const override;
  Trajectory ground_truth() override;
  std::optional<double> progress() const override;

 protected:
  bool read_imu(ImuSample& sample) override;
  bool read_scan(LidarScan& scan) override;

 private:
  struct ScanFile {
    int64_t utime_us = 0;
    std::string path;
  };

  std::string folder_;
  FolderDatasetConfig config_;
  std::vector<ScanFile> scan_files_;  // in time order
  size_t next_scan_file_ = 0;
  std::unique_ptr<TextLineReader> imu_;
};

}  // namespace liloc::dataset
