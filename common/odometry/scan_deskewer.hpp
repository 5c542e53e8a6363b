#pragma once
// Motion compensation: every point of a sweep is moved from where the body was when it
// was measured to the body frame at the end of the sweep.

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "odometry/motion_profile.hpp"
#include "pointcloud/point_cloud.hpp"

namespace liloc {

// Points (lidar frame, with their time offsets after sweep_start_utime, IMU clock) to
// the body frame at end_utime: p_end = T_local_body(end)^-1 T_local_body(t_i)
// T_body_lidar p_i.
std::vector<Eigen::Vector3f> deskew(const std::vector<LidarPoint>& points,
                                    int64_t sweep_start_utime, int64_t end_utime,
                                    const MotionProfile& motion,
                                    const Eigen::Isometry3d& T_body_lidar);

}  // namespace liloc
