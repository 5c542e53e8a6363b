#pragma once
// KITTI odometry benchmark (HDL-64E, 10 Hz, no IMU):
//   <root>/sequences/<seq>/velodyne/NNNNNN.bin   float32 x, y, z, reflectance per point
//   <root>/sequences/<seq>/times.txt             one time per scan, s since the sequence start
//   <root>/sequences/<seq>/calib.txt             "Tr:" = T_cam0_velo, 3x4 row-major
//   <root>/poses/<seq>.txt                       optional: T_cam0(0)_cam0(i), 3x4 row-major
//
// Frames: points stay in the velodyne frame (x forward, y left, z up). With no IMU, the
// body frame is the velodyne frame; ground truth is T_velo(0)_velo(i) = Tr^-1 P_i Tr.
//
// Times: times.txt is the camera trigger, when the laser faces forward, i.e. the middle
// of the sweep (the sweep starts and ends facing backwards). A sweep therefore starts
// at t - scan_period_s / 2 and the ground-truth pose at t is the mid-sweep pose.
// The points carry no time. The odometry release is already motion compensated to the
// frame time (its readme says so), so by default every point is stamped at the frame
// time: a deskewer then leaves the sweep unchanged. "azimuth" instead derives the time
// from the rotation (start behind, clockwise seen from above), for uncompensated sweeps.
// Ring is 0: the release carries no laser index and the HDL-64E's elevation table is not
// uniform enough to recover it from the elevation reliably.

#include <string>
#include <vector>

#include "dataset/sensor_dataset_reader.hpp"

namespace liloc::dataset {

struct KittiConfig {
  // times.txt starts at 0; utime = (time_origin_s + t) * 1e6. The origin keeps the first
  // sweep's start (t - scan_period_s / 2) after the epoch.
  double time_origin_s = 1.0;
  std::string point_time = "frame_time";  // "frame_time" or "azimuth"
  double scan_period_s = 0.1;

  template <class V>
  void visit_fields(V& v) {
    v("time_origin_s", time_origin_s);
    v("point_time", point_time);
    v("scan_period_s", scan_period_s);
  }
  void validate() const;
};

class KittiOdometryReader : public SensorDatasetReader {
 public:
  // Reads times.txt (small) at once; throws DatasetError if it or calib.txt is missing
  // or malformed.
  KittiOdometryReader(const std::string& root, const std::string& sequence,
                      KittiConfig config = {});

  SensorSetup sensor_setup() const override;
  // Empty if poses/<seq>.txt does not exist (sequences 11-21).
  Trajectory ground_truth() override;
  std::optional<double> progress() const override;

 protected:
  bool read_imu(ImuSample& sample) override;
  bool read_scan(LidarScan& scan) override;

 private:
  std::string sequence_dir_;
  std::string poses_path_;
  KittiConfig config_;
  std::vector<double> frame_times_s_;
  Eigen::Isometry3d T_cam_velo_ = Eigen::Isometry3d::Identity();
  size_t next_frame_ = 0;
};

// The points of one velodyne .bin file (float32 x, y, z, reflectance each), their times
// unset; non-finite points are dropped and counted. Throws DatasetError naming the file.
std::vector<LidarPoint> read_kitti_bin(const std::string& path,
                                       int64_t* dropped_non_finite = nullptr);

}  // namespace liloc::dataset
