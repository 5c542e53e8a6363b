#include "dataset/kitti_odometry_reader.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "dataset/dataset_error.hpp"
#include "dataset/text_line_reader.hpp"
#include "math/se3.hpp"

namespace liloc::dataset {
namespace {

constexpr size_t kBytesPerPoint = 4 * sizeof(float);

// A KITTI 3x4 row-major matrix; the rotation is re-orthonormalized because the files
// print it with 7 significant digits.
Eigen::Isometry3d isometry_from_3x4(const std::vector<double>& v) {
  Eigen::Matrix3d R;
  R << v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10];
  return se3::make(Eigen::Quaterniond(R).normalized(), Eigen::Vector3d(v[3], v[7], v[11]));
}

Eigen::Isometry3d read_T_cam_velo(const std::string& path) {
  TextLineReader reader(path);
  for (std::string line; reader.next(line);) {
    if (line.rfind("Tr:", 0) == 0) {
      return isometry_from_3x4(reader.numbers(line.substr(3), ' ', 12));
    }
  }
  throw DatasetError::in_file(path, "no 'Tr:' line (velodyne to camera transform)");
}

}  // namespace

void KittiConfig::validate() const {
  if (point_time != "frame_time" && point_time != "azimuth") {
    throw std::invalid_argument("point_time must be 'frame_time' or 'azimuth'");
  }
  if (!(scan_period_s > 0.0)) {
    throw std::invalid_argument("scan_period_s must be > 0");
  }
  if (!(time_origin_s >= scan_period_s / 2)) {
    throw std::invalid_argument("time_origin_s must be >= scan_period_s / 2");
  }
}

KittiOdometryReader::KittiOdometryReader(const std::string& root, const std::string& sequence,
                                         KittiConfig config)
    : sequence_dir_(root + "/sequences/" + sequence),
      poses_path_(root + "/poses/" + sequence + ".txt"),
      config_(std::move(config)) {
  config_.validate();
  TextLineReader times(sequence_dir_ + "/times.txt");
  for (std::string line; times.next(line);) {
    const double t = times.numbers(line, ' ', 1)[0];
    if (!std::isfinite(t)) {
      times.fail("non-finite time");
    }
    frame_times_s_.push_back(t);
  }
  if (frame_times_s_.empty()) {
    throw DatasetError::in_file(times.path(), "no scan times");
  }
  T_cam_velo_ = read_T_cam_velo(sequence_dir_ + "/calib.txt");
}

SensorSetup KittiOdometryReader::sensor_setup() const {
  SensorSetup setup;
  setup.sensor_model = "hdl64";
  setup.has_imu = false;
  setup.nominal_scan_period_s = static_cast<float>(config_.scan_period_s);
  setup.T_body_lidar = Eigen::Isometry3d::Identity();
  return setup;
}

Trajectory KittiOdometryReader::ground_truth() {
  if (!std::filesystem::exists(poses_path_)) {
    return Trajectory();
  }
  TextLineReader reader(poses_path_);
  const Eigen::Isometry3d T_velo_cam = T_cam_velo_.inverse();
  std::vector<StampedPose> poses;
  for (std::string line; reader.next(line);) {
    const std::vector<double> v = reader.numbers(line, ' ', 12);
    if (!std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); })) {
      reader.fail("non-finite value");
    }
    if (poses.size() == frame_times_s_.size()) {
      reader.fail("more poses than the " + std::to_string(frame_times_s_.size()) +
                  " scan times in times.txt");
    }
    const double time_s = config_.time_origin_s + frame_times_s_[poses.size()];
    poses.push_back({time_s, T_velo_cam * isometry_from_3x4(v) * T_cam_velo_});
  }
  if (poses.size() != frame_times_s_.size()) {
    throw DatasetError::in_file(poses_path_, std::to_string(poses.size()) + " poses for " +
                                                 std::to_string(frame_times_s_.size()) +
                                                 " scan times in times.txt");
  }
  try {
    return Trajectory(std::move(poses));
  } catch (const std::invalid_argument& e) {
    throw DatasetError::in_file(poses_path_, e.what());
  }
}

std::optional<double> KittiOdometryReader::progress() const {
  return static_cast<double>(next_frame_) / static_cast<double>(frame_times_s_.size());
}

bool KittiOdometryReader::read_imu(ImuSample&) { return false; }

bool KittiOdometryReader::read_scan(LidarScan& scan) {
  if (next_frame_ == frame_times_s_.size()) {
    return false;
  }
  char name[16];
  std::snprintf(name, sizeof(name), "%06zu.bin", next_frame_);
  int64_t dropped = 0;
  scan.points = read_kitti_bin(sequence_dir_ + "/velodyne/" + name, &dropped);
  mutable_stats().dropped_non_finite_points += dropped;

  const double period_s = config_.scan_period_s;
  const bool time_from_azimuth = config_.point_time == "azimuth";
  const double frame_time_s = config_.time_origin_s + frame_times_s_[next_frame_];
  scan.utime_us = static_cast<int64_t>(std::llround((frame_time_s - period_s / 2) * 1e6));
  scan.scan_period_s = static_cast<float>(period_s);
  for (LidarPoint& p : scan.points) {
    if (time_from_azimuth) {
      // Clockwise from behind: azimuth 180 deg at the start, 0 (forward) at the middle.
      const double azimuth = std::atan2(p.position_m.y(), p.position_m.x());
      p.time_offset_s = static_cast<float>(period_s * (M_PI - azimuth) / (2 * M_PI));
    } else {
      p.time_offset_s = static_cast<float>(period_s / 2);
    }
  }
  ++next_frame_;
  return true;
}

std::vector<LidarPoint> read_kitti_bin(const std::string& path, int64_t* dropped_non_finite) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw DatasetError::in_file(path, "cannot open");
  }
  const uint64_t size = std::filesystem::file_size(path);
  if (size % kBytesPerPoint != 0) {
    throw DatasetError::at_byte(path, size - size % kBytesPerPoint,
                                "truncated point: file size " + std::to_string(size) +
                                    " is not a multiple of 16 bytes (float32 x, y, z, "
                                    "reflectance)");
  }
  std::vector<float> values(size / sizeof(float));
  if (!in.read(reinterpret_cast<char*>(values.data()), static_cast<std::streamsize>(size))) {
    throw DatasetError::at_byte(path, static_cast<uint64_t>(in.gcount()), "read failed");
  }
  std::vector<LidarPoint> points;
  points.reserve(values.size() / 4);
  for (size_t i = 0; i + 3 < values.size(); i += 4) {
    LidarPoint p;
    p.position_m = Eigen::Vector3f(values[i], values[i + 1], values[i + 2]);
    p.intensity = values[i + 3];
    if (!p.position_m.allFinite() || !std::isfinite(p.intensity)) {
      if (dropped_non_finite != nullptr) {
        ++*dropped_non_finite;
      }
      continue;
    }
    points.push_back(p);
  }
  return points;
}

}  // namespace liloc::dataset
