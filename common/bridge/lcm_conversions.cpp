#include "bridge/lcm_conversions.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace liloc::bridge {
namespace {
bool all_finite(const double* v, int n) {
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(v[i])) {
      return false;
    }
  }
  return true;
}

void count(size_t* counter, size_t n) {
  if (counter != nullptr) {
    *counter = n;
  }
}
}  // namespace

liloc::header_t make_header(int64_t utime, const std::string& robot_id,
                            const std::string& frame_id) {
  liloc::header_t h;
  h.utime = utime;
  h.seq = 0;
  h.robot_id = robot_id;
  h.frame_id = frame_id;
  return h;
}

liloc::pose3_t to_msg(const Eigen::Isometry3d& T) {
  liloc::pose3_t msg;
  const Eigen::Quaterniond q(T.linear());
  const Eigen::Vector3d& t = T.translation();
  for (int i = 0; i < 3; ++i) {
    msg.position[i] = t[i];
  }
  msg.orientation[0] = q.w();
  msg.orientation[1] = q.x();
  msg.orientation[2] = q.y();
  msg.orientation[3] = q.z();
  return msg;
}

Eigen::Isometry3d from_msg(const liloc::pose3_t& msg) {
  if (!all_finite(msg.position, 3) || !all_finite(msg.orientation, 4)) {
    throw std::invalid_argument("pose has a non-finite value");
  }
  const Eigen::Quaterniond q(msg.orientation[0], msg.orientation[1], msg.orientation[2],
                             msg.orientation[3]);
  if (std::abs(q.norm() - 1.0) > 1e-3) {
    throw std::invalid_argument("pose quaternion has norm " + std::to_string(q.norm()) + ", not 1");
  }
  return se3::make(q, Eigen::Vector3d(msg.position[0], msg.position[1], msg.position[2]));
}

void to_msg(const Matrix6d& covariance, double (&out)[36]) {
  Eigen::Map<Eigen::Matrix<double, 6, 6, Eigen::RowMajor>> wire(out);
  wire = covariance;
}

Matrix6d covariance_from_msg(const double (&values)[36]) {
  return Eigen::Map<const Eigen::Matrix<double, 6, 6, Eigen::RowMajor>>(values);
}

liloc::point_cloud_t to_msg(const PointCloud& cloud) {
  liloc::point_cloud_t msg;
  const size_t n = cloud.size();
  msg.num_points = static_cast<int32_t>(n);
  msg.x.resize(n);
  msg.y.resize(n);
  msg.z.resize(n);
  msg.intensity = cloud.intensities;
  for (size_t i = 0; i < n; ++i) {
    msg.x[i] = cloud.points[i].x();
    msg.y[i] = cloud.points[i].y();
    msg.z[i] = cloud.points[i].z();
  }
  return msg;
}

PointCloud from_msg(const liloc::point_cloud_t& msg, size_t* non_finite) {
  PointCloud cloud;
  cloud.reserve(static_cast<size_t>(msg.num_points));
  size_t bad = 0;
  for (int32_t i = 0; i < msg.num_points; ++i) {
    const Eigen::Vector3f p(msg.x[i], msg.y[i], msg.z[i]);
    if (!p.allFinite()) {
      ++bad;
      continue;
    }
    cloud.push_back(p, std::isfinite(msg.intensity[i]) ? msg.intensity[i] : 0.0f);
  }
  count(non_finite, bad);
  return cloud;
}

liloc::compact_cloud_t to_msg(const CompactCloud& cloud) {
  liloc::compact_cloud_t msg;
  msg.resolution_m = cloud.resolution_m;
  msg.intensity_scale = cloud.intensity_scale;
  msg.num_points = static_cast<int32_t>(cloud.size());
  msg.x = cloud.x;
  msg.y = cloud.y;
  msg.z = cloud.z;
  msg.intensity = cloud.intensity;
  return msg;
}

CompactCloud from_msg(const liloc::compact_cloud_t& msg) {
  CompactCloud cloud;
  cloud.resolution_m = msg.resolution_m;
  cloud.intensity_scale = msg.intensity_scale;
  cloud.x = msg.x;
  cloud.y = msg.y;
  cloud.z = msg.z;
  cloud.intensity = msg.intensity;
  check_compact_cloud(cloud);
  if (cloud.size() != static_cast<size_t>(std::max(msg.num_points, 0))) {
    throw std::invalid_argument("compact cloud: " + std::to_string(cloud.size()) +
                                " points, num_points " + std::to_string(msg.num_points));
  }
  return cloud;
}

liloc::lidar_scan_t to_msg(const LidarScan& scan, const std::string& robot_id,
                           const std::string& frame_id, const std::string& sensor_model) {
  liloc::lidar_scan_t msg;
  msg.header = make_header(scan.utime_us, robot_id, frame_id);
  msg.sensor_model = sensor_model;
  msg.scan_period_s = scan.scan_period_s;
  const size_t n = scan.points.size();
  msg.num_points = static_cast<int32_t>(n);
  msg.x.resize(n);
  msg.y.resize(n);
  msg.z.resize(n);
  msg.intensity.resize(n);
  msg.time_offset_s.resize(n);
  msg.ring.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const LidarPoint& p = scan.points[i];
    msg.x[i] = p.position_m.x();
    msg.y[i] = p.position_m.y();
    msg.z[i] = p.position_m.z();
    msg.intensity[i] = p.intensity;
    msg.time_offset_s[i] = p.time_offset_s;
    msg.ring[i] = p.ring;
  }
  return msg;
}

LidarScan from_msg(const liloc::lidar_scan_t& msg, size_t* non_finite) {
  LidarScan scan;
  scan.utime_us = msg.header.utime;
  scan.scan_period_s = msg.scan_period_s;
  scan.points.reserve(static_cast<size_t>(msg.num_points));
  size_t bad = 0;
  for (int32_t i = 0; i < msg.num_points; ++i) {
    LidarPoint p;
    p.position_m = Eigen::Vector3f(msg.x[i], msg.y[i], msg.z[i]);
    p.intensity = msg.intensity[i];
    p.time_offset_s = msg.time_offset_s[i];
    p.ring = msg.ring[i];
    if (!p.position_m.allFinite() || !std::isfinite(p.intensity) ||
        !std::isfinite(p.time_offset_s)) {
      ++bad;
      continue;
    }
    scan.points.push_back(p);
  }
  count(non_finite, bad);
  return scan;
}

liloc::imu_sample_t to_msg(const ImuSample& sample) {
  liloc::imu_sample_t msg;
  msg.utime = sample.utime_us;
  for (int i = 0; i < 3; ++i) {
    msg.linear_acceleration[i] = sample.accel_mps2[i];
    msg.angular_velocity[i] = sample.gyro_rps[i];
  }
  return msg;
}

liloc::imu_t to_msg(const std::vector<ImuSample>& samples, const std::string& robot_id,
                    const std::string& frame_id) {
  liloc::imu_t msg;
  msg.header = make_header(samples.empty() ? 0 : samples.back().utime_us, robot_id, frame_id);
  msg.num_samples = static_cast<int32_t>(samples.size());
  msg.samples.reserve(samples.size());
  for (const ImuSample& s : samples) {
    msg.samples.push_back(to_msg(s));
  }
  return msg;
}

std::vector<ImuSample> from_msg(const liloc::imu_t& msg, size_t* non_finite) {
  std::vector<ImuSample> samples;
  samples.reserve(msg.samples.size());
  size_t bad = 0;
  for (const liloc::imu_sample_t& s : msg.samples) {
    if (!all_finite(s.linear_acceleration, 3) || !all_finite(s.angular_velocity, 3)) {
      ++bad;
      continue;
    }
    ImuSample out;
    out.utime_us = s.utime;
    out.accel_mps2 = Eigen::Vector3d(s.linear_acceleration);
    out.gyro_rps = Eigen::Vector3d(s.angular_velocity);
    samples.push_back(out);
  }
  count(non_finite, bad);
  return samples;
}

}  // namespace liloc::bridge
