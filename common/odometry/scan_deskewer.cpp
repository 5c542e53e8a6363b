#include "odometry/scan_deskewer.hpp"

#include <cmath>

namespace liloc {

std::vector<Eigen::Vector3f> deskew(const std::vector<LidarPoint>& points,
                                    int64_t sweep_start_utime, int64_t end_utime,
                                    const MotionProfile& motion,
                                    const Eigen::Isometry3d& T_body_lidar) {
  std::vector<Eigen::Vector3f> out;
  out.reserve(points.size());
  const Eigen::Isometry3d T_end_local = motion.pose_at(end_utime).inverse();
  // Points fired together share a transform; most sweeps come in firing order. Times are
  // quantized to 50 us (0.5 mm at 10 m/s) so that non-repetitive sensors, whose every
  // point has its own time, share transforms too.
  constexpr int64_t kQuantumUs = 50;
  int64_t cached_time = INT64_MIN;
  Eigen::Isometry3f T_end_lidar = Eigen::Isometry3f::Identity();
  for (const LidarPoint& p : points) {
    const int64_t t =
        sweep_start_utime + std::llround(p.time_offset_s * 1e6 / kQuantumUs) * kQuantumUs;
    if (t != cached_time) {
      cached_time = t;
      T_end_lidar = (T_end_local * motion.pose_at(t) * T_body_lidar).cast<float>();
    }
    out.push_back(T_end_lidar * p.position_m);
  }
  return out;
}

}  // namespace liloc
