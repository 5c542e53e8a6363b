#include "bridge/message_samples.hpp"

#include "bridge/lcm_conversions.hpp"
#include "math/so3.hpp"

namespace liloc::bridge {
namespace {
constexpr int64_t kUtime = 1700000000123456;  // 2023-11-14, an arbitrary fixed time

liloc::pose3_t sample_pose(double k) {
  return to_msg(se3::make(so3::exp(Eigen::Vector3d(0.1 * k, -0.2, 0.3)),
                          Eigen::Vector3d(1.0 * k, 2.0, -3.0)));
}

template <size_t N>
void fill(double (&values)[N], double start) {
  for (size_t i = 0; i < N; ++i) {
    values[i] = start + 0.5 * static_cast<double>(i);
  }
}

PointCloud sample_cloud(int n) {
  PointCloud cloud;
  for (int i = 0; i < n; ++i) {
    cloud.push_back(Eigen::Vector3f(0.5f * i, -0.25f * i, 1.0f + 0.1f * i), 10.0f * i);
  }
  return cloud;
}
}  // namespace

template <>
liloc::header_t make_sample<liloc::header_t>(const std::string& robot_id) {
  return make_header(kUtime, robot_id, "odom");
}

template <>
liloc::pose3_t make_sample<liloc::pose3_t>(const std::string&) {
  return sample_pose(1.0);
}

template <>
liloc::imu_sample_t make_sample<liloc::imu_sample_t>(const std::string&) {
  ImuSample s;
  s.utime_us = kUtime;
  s.accel_mps2 = Eigen::Vector3d(0.1, -0.2, 9.81);
  s.gyro_rps = Eigen::Vector3d(0.01, 0.02, -0.03);
  return to_msg(s);
}

template <>
liloc::imu_t make_sample<liloc::imu_t>(const std::string& robot_id) {
  std::vector<ImuSample> samples(3);
  for (size_t i = 0; i < samples.size(); ++i) {
    samples[i].utime_us = kUtime + 5000 * static_cast<int64_t>(i);
    samples[i].accel_mps2 = Eigen::Vector3d(0.1 * i, 0.0, 9.81);
    samples[i].gyro_rps = Eigen::Vector3d(0.0, 0.01 * i, 0.0);
  }
  return to_msg(samples, robot_id, "imu");
}

template <>
liloc::lidar_scan_t make_sample<liloc::lidar_scan_t>(const std::string& robot_id) {
  LidarScan scan;
  scan.utime_us = kUtime;
  scan.scan_period_s = 0.1f;
  for (int i = 0; i < 16; ++i) {
    LidarPoint p;
    p.position_m = Eigen::Vector3f(10.0f + i, 0.5f * i, -1.5f);
    p.intensity = 3.0f * i;
    p.time_offset_s = 0.1f * i / 16.0f;
    p.ring = static_cast<uint8_t>(i);
    scan.points.push_back(p);
  }
  return to_msg(scan, robot_id, "lidar", "vlp16");
}

template <>
liloc::point_cloud_t make_sample<liloc::point_cloud_t>(const std::string&) {
  return to_msg(sample_cloud(8));
}

template <>
liloc::compact_cloud_t make_sample<liloc::compact_cloud_t>(const std::string&) {
  return to_msg(quantize(sample_cloud(8)));
}

template <>
liloc::odometry_t make_sample<liloc::odometry_t>(const std::string& robot_id) {
  liloc::odometry_t m;
  m.header = make_header(kUtime, robot_id, "odom");
  m.child_frame_id = "body";
  m.pose = sample_pose(2.0);
  fill(m.linear_velocity, 1.0);
  fill(m.angular_velocity, -0.1);
  fill(m.covariance, 0.001);
  fill(m.gyro_bias, 0.0001);
  fill(m.accel_bias, 0.01);
  return m;
}

template <>
liloc::pose_t make_sample<liloc::pose_t>(const std::string& robot_id) {
  liloc::pose_t m;
  m.header = make_header(kUtime, robot_id, "map");
  m.child_frame_id = "body";
  m.pose = sample_pose(3.0);
  fill(m.covariance, 0.1);
  return m;
}

template <>
liloc::keyframe_t make_sample<liloc::keyframe_t>(const std::string& robot_id) {
  liloc::keyframe_t m;
  m.header = make_header(kUtime, robot_id, "odom");
  m.keyframe_id = 42;
  m.child_frame_id = "body";
  m.pose = sample_pose(4.0);
  fill(m.linear_velocity, 2.0);
  fill(m.gyro_bias, 0.0002);
  fill(m.accel_bias, 0.02);
  fill(m.covariance, 0.002);
  m.fitness = 0.05f;
  m.degenerate = false;
  m.gravity_body[2] = -1.0;
  m.gravity_sigma = 0.002f;
  m.cloud = to_msg(sample_cloud(12));
  return m;
}

template <>
liloc::submap_request_t make_sample<liloc::submap_request_t>(const std::string& robot_id) {
  liloc::submap_request_t m;
  m.header = make_header(kUtime, robot_id, "map");
  m.request_id = 7;
  m.query = liloc::submap_request_t::QUERY_BY_ID;
  fill(m.position, 10.0);
  m.radius_m = 30.0;
  m.max_submaps = 4;
  m.submap_ids = {3, 5};
  m.num_ids = 2;
  m.include_clouds = true;
  return m;
}

template <>
liloc::descriptor_request_t make_sample<liloc::descriptor_request_t>(const std::string& robot_id) {
  liloc::descriptor_request_t m;
  m.header = make_header(kUtime, robot_id, "map");
  m.request_id = 9;
  return m;
}

template <>
liloc::keyframe_descriptors_t make_sample<liloc::keyframe_descriptors_t>(
    const std::string& robot_id) {
  liloc::keyframe_descriptors_t m;
  m.header = make_header(kUtime, robot_id, "map");
  m.request_id = 9;
  m.map_version = 3;
  m.chunk_index = 1;
  m.num_chunks = 2;
  m.num_keyframes = 2;
  m.keyframe_ids = {40, 41};
  m.submap_ids = {2, 2};
  m.keyframe_poses = {sample_pose(7.0), sample_pose(8.0)};
  m.descriptor_offsets = {0, 3};
  m.descriptors = {'L', 'P', 'D', '1', 2, 0};
  m.num_bytes = 6;
  return m;
}

template <>
liloc::submap_t make_sample<liloc::submap_t>(const std::string& robot_id) {
  liloc::submap_t m;
  m.header = make_header(kUtime, robot_id, "map");
  m.request_id = 7;
  m.reply_index = 0;
  m.reply_count = 2;
  m.map_version = 3;
  m.submap_id = 5;
  m.chunk_index = 0;
  m.num_chunks = 2;
  m.submap_num_keyframes = 20;
  fill(m.centroid, 50.0);
  m.bounds_xy[0] = 40.0;
  m.bounds_xy[1] = 60.0;
  m.bounds_xy[2] = 45.0;
  m.bounds_xy[3] = 65.0;
  m.num_keyframes = 2;
  m.keyframe_ids = {100, 101};
  m.keyframe_poses = {sample_pose(5.0), sample_pose(6.0)};
  m.keyframe_fitness = {0.04f, 0.05f};
  m.cloud_offsets = {0, 4};
  m.cloud = to_msg(quantize(sample_cloud(9)));
  return m;
}

template <>
liloc::map_update_t make_sample<liloc::map_update_t>(const std::string& robot_id) {
  liloc::map_update_t m;
  m.header = make_header(kUtime, robot_id, "map");
  m.session_id = robot_id + "-session";
  m.update_id = 11;
  m.chunk_index = 1;
  m.num_chunks = 3;
  m.base_map_version = 2;
  m.num_keyframes = 2;
  m.keyframe_ids = {7, 8};
  m.keyframe_utimes = {kUtime, kUtime + 100000};
  m.keyframe_poses = {sample_pose(7.0), sample_pose(8.0)};
  m.keyframe_fitness = {0.03f, 0.06f};
  m.cloud_offsets = {0, 5};
  m.cloud = to_msg(sample_cloud(10));
  return m;
}

template <>
liloc::submap_info_t make_sample<liloc::submap_info_t>(const std::string&) {
  liloc::submap_info_t m;
  m.submap_id = 9;
  m.num_keyframes = 20;
  fill(m.centroid, -5.0);
  fill(m.bounds_xy, -20.0);
  m.source_session = "A";
  return m;
}

template <>
liloc::map_info_t make_sample<liloc::map_info_t>(const std::string& robot_id) {
  liloc::map_info_t m;
  m.header = make_header(kUtime, robot_id, "map");
  m.map_id = "campus";
  m.map_version = 4;
  m.num_keyframes = 40;
  m.updates_merged = 1;
  m.updates_rejected = 2;
  m.submaps = {make_sample<liloc::submap_info_t>(robot_id),
               make_sample<liloc::submap_info_t>(robot_id)};
  m.submaps[1].submap_id = 10;
  m.num_submaps = 2;
  return m;
}

template <>
liloc::init_result_t make_sample<liloc::init_result_t>(const std::string& robot_id) {
  liloc::init_result_t m;
  m.header = make_header(kUtime, robot_id, "map");
  m.status = liloc::init_result_t::STATUS_SUCCESS;
  m.method = "coarse_to_fine";
  m.message = "matched keyframe 12 of submap 3";
  m.keyframe_id = 0;
  m.pose = sample_pose(9.0);
  fill(m.covariance, 0.01);
  m.fitness = 0.08f;
  m.descriptor_distance = 0.2f;
  m.matched_submap_id = 3;
  m.matched_keyframe_id = 12;
  m.time_ms = 1630.0f;
  return m;
}

template <>
liloc::correction_t make_sample<liloc::correction_t>(const std::string& robot_id) {
  liloc::correction_t m;
  m.header = make_header(kUtime, robot_id, "odom");
  m.keyframe_id = 5;
  m.has_pose = true;
  m.pose = sample_pose(10.0);
  m.has_velocity = true;
  fill(m.linear_velocity, 3.0);
  m.has_bias = true;
  fill(m.gyro_bias, 0.0003);
  fill(m.accel_bias, 0.03);
  return m;
}

template <>
liloc::status_t make_sample<liloc::status_t>(const std::string& robot_id) {
  liloc::status_t m;
  m.header = make_header(kUtime, robot_id, "");
  m.process = "odometry";
  m.mode = liloc::status_t::MODE_ILM;
  m.overlap = 0.4f;
  m.fitness = 0.05f;
  m.degenerate = true;
  m.min_eigenvalue = 12.5f;
  m.timing_names = {"deskew", "register"};
  m.timing_ms = {1.5f, 9.25f};
  m.num_timings = 2;
  m.counter_names = {"received", "dropped"};
  m.counter_values = {1000, 3};
  m.num_counters = 2;
  m.message = "corridor: degenerate along x";
  return m;
}

}  // namespace liloc::bridge
