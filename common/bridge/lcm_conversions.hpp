#pragma once
// Conversions between liloc's LCM messages and the core types of common/. Processes
// call these at their edges; algorithm code never sees a message.
//
// Input from the wire is not trusted: non-finite points, samples and poses are dropped
// or rejected and counted, never passed on.

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "imu/imu_sample.hpp"
#include "liloc/compact_cloud_t.hpp"
#include "liloc/header_t.hpp"
#include "liloc/imu_t.hpp"
#include "liloc/lidar_scan_t.hpp"
#include "liloc/point_cloud_t.hpp"
#include "liloc/pose3_t.hpp"
#include "math/se3.hpp"
#include "pointcloud/compact_cloud.hpp"
#include "pointcloud/point_cloud.hpp"

namespace liloc::bridge {

liloc::header_t make_header(int64_t utime, const std::string& robot_id,
                            const std::string& frame_id);

liloc::pose3_t to_msg(const Eigen::Isometry3d& T);
// Throws std::invalid_argument if a value is not finite or the quaternion's norm is far
// from 1 (it is normalized otherwise).
Eigen::Isometry3d from_msg(const liloc::pose3_t& msg);

void to_msg(const Matrix6d& covariance, double (&out)[36]);
Matrix6d covariance_from_msg(const double (&values)[36]);

liloc::point_cloud_t to_msg(const PointCloud& cloud);
// Points with a non-finite coordinate are dropped and counted in *non_finite.
PointCloud from_msg(const liloc::point_cloud_t& msg, size_t* non_finite = nullptr);

// compact_cloud_t <-> CompactCloud: copies, the quantization is done (quantize()).
liloc::compact_cloud_t to_msg(const CompactCloud& cloud);
// Throws std::invalid_argument for a resolution or scale that is not positive and finite,
// or arrays that disagree with num_points.
CompactCloud from_msg(const liloc::compact_cloud_t& msg);

liloc::lidar_scan_t to_msg(const LidarScan& scan, const std::string& robot_id,
                           const std::string& frame_id, const std::string& sensor_model);
// Points with a non-finite coordinate, intensity or time offset are dropped and counted
// in *non_finite.
LidarScan from_msg(const liloc::lidar_scan_t& msg, size_t* non_finite = nullptr);

liloc::imu_sample_t to_msg(const ImuSample& sample);
liloc::imu_t to_msg(const std::vector<ImuSample>& samples, const std::string& robot_id,
                    const std::string& frame_id);
// Samples with a non-finite value are dropped and counted in *non_finite.
std::vector<ImuSample> from_msg(const liloc::imu_t& msg, size_t* non_finite = nullptr);

}  // namespace liloc::bridge
