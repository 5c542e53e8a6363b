#include "dataset/folder_dataset_reader.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "dataset/dataset_error.hpp"
#include "dataset/pcd_scan_reader.hpp"
#include "dataset/tum_trajectory.hpp"

namespace liloc::dataset {
namespace {

namespace fs = std::filesystem;

// File-name times from here on are nanoseconds: 1e12 s is 30000 years away, while
// nanosecond stamps of any real recording are far above it.
constexpr double kNanosecondNameMin = 1e12;
const char* const kImuHeader = "time_s,ax,ay,az,gx,gy,gz";

int64_t utime_from_file_name(const fs::path& path) {
  const std::string stem = path.stem().string();
  char* end = nullptr;
  const double value = std::strtod(stem.c_str(), &end);
  if (stem.empty() || *end != '\0' || !std::isfinite(value) || value < 0) {
    throw DatasetError::in_file(path.string(), "file name is not a time (seconds or nanoseconds)");
  }
  if (value < kNanosecondNameMin) {
    return static_cast<int64_t>(std::llround(value * 1e6));
  }
  if (!std::all_of(stem.begin(), stem.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    throw DatasetError::in_file(path.string(), "a nanosecond file name must be an integer");
  }
  // Integer parsing: a double holds nanoseconds since the epoch only to ~256 ns.
  const long long ns = std::strtoll(stem.c_str(), nullptr, 10);
  return static_cast<int64_t>((ns + 500) / 1000);
}

std::string without_spaces(const std::string& s) {
  std::string out;
  std::copy_if(s.begin(), s.end(), std::back_inserter(out), [](char c) { return c != ' '; });
  return out;
}

}  // namespace

void FolderDatasetConfig::validate() const {
  if (!(scan_period_s > 0.0)) {
    throw std::invalid_argument("scan_period_s must be > 0");
  }
  if (sensor_model.empty()) {
    throw std::invalid_argument("sensor_model must not be empty");
  }
}

FolderDatasetReader::FolderDatasetReader(const std::string& folder, FolderDatasetConfig config)
    : folder_(folder), config_(std::move(config)) {
  config_.validate();
  const fs::path scans_dir = fs::path(folder) / "scans";
  if (!fs::is_directory(scans_dir)) {
    throw DatasetError::in_file(scans_dir.string(), "no such folder");
  }
  for (const fs::directory_entry& entry : fs::directory_iterator(scans_dir)) {
    if (entry.is_regular_file() && entry.path().extension() == ".pcd") {
      scan_files_.push_back({utime_from_file_name(entry.path()), entry.path().string()});
    }
  }
  std::sort(scan_files_.begin(), scan_files_.end(),
            [](const ScanFile& a, const ScanFile& b) { return a.utime_us < b.utime_us; });

  const std::string imu_path = folder + "/imu.csv";
  if (fs::exists(imu_path)) {
    imu_ = std::make_unique<TextLineReader>(imu_path);
    std::string header;
    if (!imu_->next(header) || without_spaces(header) != kImuHeader) {
      imu_->fail(std::string("expected the header '") + kImuHeader + "'");
    }
  }
}

SensorSetup FolderDatasetReader::sensor_setup() const {
  SensorSetup setup;
  setup.sensor_model = config_.sensor_model;
  setup.has_imu = imu_ != nullptr;
  setup.nominal_scan_period_s = static_cast<float>(config_.scan_period_s);
  return setup;
}

Trajectory FolderDatasetReader::ground_truth() {
  const std::string path = folder_ + "/ground_truth.tum";
  if (!fs::exists(path)) {
    return Trajectory();
  }
  try {
    return read_tum(path);
  } catch (const std::runtime_error& e) {
    throw DatasetError(e.what());  // read_tum's message already names the file and line
  }
}

std::optional<double> FolderDatasetReader::progress() const {
  if (scan_files_.empty()) {
    return 1.0;
  }
  return static_cast<double>(next_scan_file_) / static_cast<double>(scan_files_.size());
}

bool FolderDatasetReader::read_imu(ImuSample& sample) {
  std::string line;
  if (imu_ == nullptr || !imu_->next(line)) {
    return false;
  }
  const std::vector<double> v = imu_->numbers(line, ',', 7);
  if (!std::isfinite(v[0])) {
    imu_->fail("non-finite time");
  }
  sample.utime_us = static_cast<int64_t>(std::llround(v[0] * 1e6));
  sample.accel_mps2 = Eigen::Vector3d(v[1], v[2], v[3]);
  sample.gyro_rps = Eigen::Vector3d(v[4], v[5], v[6]);
  return true;
}

bool FolderDatasetReader::read_scan(LidarScan& scan) {
  if (next_scan_file_ == scan_files_.size()) {
    return false;
  }
  const ScanFile& file = scan_files_[next_scan_file_++];
  PcdScan pcd = read_pcd_scan(file.path, file.utime_us, static_cast<float>(config_.scan_period_s));
  mutable_stats().dropped_non_finite_points += pcd.dropped_non_finite_points;
  scan = std::move(pcd.scan);
  return true;
}

}  // namespace liloc::dataset
