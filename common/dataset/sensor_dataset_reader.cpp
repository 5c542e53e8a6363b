#include "dataset/sensor_dataset_reader.hpp"

#include <cmath>

namespace liloc::dataset {

int64_t scan_end_utime_us(const LidarScan& scan) {
  // The same rounding as SensorStreamWriter, so that log order and event order agree.
  return scan.utime_us + static_cast<int64_t>(std::llround(scan.scan_period_s * 1e6));
}

int64_t available_utime_us(const SensorEvent& event) {
  if (const auto* scan = std::get_if<LidarScan>(&event)) {
    return scan_end_utime_us(*scan);
  }
  return std::get<ImuSample>(event).utime_us;
}

bool SensorDatasetReader::next(SensorEvent& event) {
  fill_imu();
  fill_scan();
  if (!next_imu_ && !next_scan_) {
    return false;
  }
  const bool imu_first =
      next_imu_ && (!next_scan_ || next_imu_->utime_us <= scan_end_utime_us(*next_scan_));
  if (imu_first) {
    event = std::move(*next_imu_);
    next_imu_.reset();
    ++stats_.imu_samples;
  } else {
    stats_.points += static_cast<int64_t>(next_scan_->points.size());
    event = std::move(*next_scan_);
    next_scan_.reset();
    ++stats_.scans;
  }
  return true;
}

void SensorDatasetReader::fill_imu() {
  while (!next_imu_ && !imu_ended_) {
    ImuSample sample;
    if (!read_imu(sample)) {
      imu_ended_ = true;
    } else if (!sample.accel_mps2.allFinite() || !sample.gyro_rps.allFinite()) {
      ++stats_.dropped_non_finite_imu_samples;
    } else if (last_imu_utime_us_ && sample.utime_us <= *last_imu_utime_us_) {
      ++stats_.dropped_imu_samples_not_increasing;
    } else {
      last_imu_utime_us_ = sample.utime_us;
      next_imu_ = sample;
    }
  }
}

void SensorDatasetReader::fill_scan() {
  while (!next_scan_ && !scans_ended_) {
    LidarScan scan;
    if (!read_scan(scan)) {
      scans_ended_ = true;
    } else if (scan.points.empty()) {
      ++stats_.dropped_empty_scans;
    } else if (last_scan_end_utime_us_ && scan_end_utime_us(scan) <= *last_scan_end_utime_us_) {
      ++stats_.dropped_scans_not_increasing;
    } else {
      last_scan_end_utime_us_ = scan_end_utime_us(scan);
      next_scan_ = std::move(scan);
    }
  }
}

}  // namespace liloc::dataset
