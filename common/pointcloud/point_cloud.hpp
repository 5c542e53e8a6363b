#pragma once
// Core point types. Algorithm code works on these, never on messages or PCL types;
// bridge/ converts at the edges.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace liloc {

// One return of a LiDAR sweep, in the lidar frame.
struct LidarPoint {
  Eigen::Vector3f position_m = Eigen::Vector3f::Zero();
  float intensity = 0.0f;
  float time_offset_s = 0.0f;  // after the start of the sweep
  uint8_t ring = 0;            // laser index, 0 = lowest
};

// A sweep as the sensor delivered it: not deskewed, points in measurement order.
struct LidarScan {
  int64_t utime_us = 0;        // start of the sweep
  float scan_period_s = 0.1f;  // nominal sweep duration
  std::vector<LidarPoint> points;
};

// A cloud of positions with intensities, in a frame named by its owner
// (keyframe clouds in the body frame, submaps in the map frame, ...).
struct PointCloud {
  std::vector<Eigen::Vector3f> points;  // metres
  std::vector<float> intensities;       // one per point

  size_t size() const { return points.size(); }
  bool empty() const { return points.empty(); }
  void reserve(size_t n) {
    points.reserve(n);
    intensities.reserve(n);
  }
  void push_back(const Eigen::Vector3f& p, float intensity) {
    points.push_back(p);
    intensities.push_back(intensity);
  }
};

}  // namespace liloc
