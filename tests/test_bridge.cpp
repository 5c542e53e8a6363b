#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "bridge/lcm_conversions.hpp"
#include "bridge/map_conversions.hpp"
#include "bridge/odometry_conversions.hpp"
#include "bridge/pcl_conversions.hpp"
#include "bridge/sensor_stream.hpp"
#include "math/so3.hpp"

namespace liloc::bridge {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

TEST(LcmConversions, PoseRoundTrip) {
  const Eigen::Isometry3d T =
      se3::make(so3::exp(Eigen::Vector3d(0.3, -1.2, 2.0)), Eigen::Vector3d(1, -2, 3));
  const liloc::pose3_t msg = to_msg(T);
  EXPECT_TRUE(from_msg(msg).isApprox(T, 1e-12));
  // Quaternion order on the wire is w, x, y, z.
  const liloc::pose3_t identity = to_msg(Eigen::Isometry3d::Identity());
  EXPECT_EQ(identity.orientation[0], 1.0);
}

TEST(LcmConversions, RejectsNonFiniteOrNonUnitPoses) {
  liloc::pose3_t msg = to_msg(Eigen::Isometry3d::Identity());
  msg.position[1] = std::numeric_limits<double>::infinity();
  EXPECT_THROW(from_msg(msg), std::invalid_argument);
  msg = to_msg(Eigen::Isometry3d::Identity());
  msg.orientation[0] = 2.0;
  EXPECT_THROW(from_msg(msg), std::invalid_argument);
  msg.orientation[0] = 1.0 + 1e-5;  // round-off is normalized, not refused
  EXPECT_NO_THROW(from_msg(msg));
}

TEST(LcmConversions, CovarianceIsRowMajor) {
  Matrix6d cov = Matrix6d::Zero();
  cov(0, 1) = 5.0;
  double wire[36];
  to_msg(cov, wire);
  EXPECT_EQ(wire[1], 5.0);
  EXPECT_EQ(wire[6], 0.0);
  EXPECT_TRUE(covariance_from_msg(wire).isApprox(cov));
}

TEST(LcmConversions, ScanRoundTripKeepsEveryField) {
  LidarScan scan;
  scan.utime_us = 123456789;
  scan.scan_period_s = 0.1f;
  for (int i = 0; i < 5; ++i) {
    LidarPoint p;
    p.position_m = Eigen::Vector3f(i, -i, 0.5f * i);
    p.intensity = 10.0f * i;
    p.time_offset_s = 0.02f * i;
    p.ring = static_cast<uint8_t>(31 - i);
    scan.points.push_back(p);
  }
  const liloc::lidar_scan_t msg = to_msg(scan, "r1", "lidar", "hdl32");
  EXPECT_EQ(msg.header.robot_id, "r1");
  EXPECT_EQ(msg.sensor_model, "hdl32");
  size_t dropped = 99;
  const LidarScan back = from_msg(msg, &dropped);
  EXPECT_EQ(dropped, 0u);
  EXPECT_EQ(back.utime_us, scan.utime_us);
  ASSERT_EQ(back.points.size(), 5u);
  EXPECT_EQ(back.points[3].position_m, scan.points[3].position_m);
  EXPECT_EQ(back.points[3].intensity, 30.0f);
  EXPECT_EQ(back.points[3].time_offset_s, scan.points[3].time_offset_s);
  EXPECT_EQ(back.points[3].ring, 28);
}

TEST(LcmConversions, KeyframeRoundTripKeepsGravity) {
  Keyframe kf;
  kf.id = 7;
  kf.utime_us = 123456789;
  kf.gravity_body = Eigen::Vector3d(0.01, -0.02, -1.0).normalized();
  kf.gravity_sigma_rad = 0.0004;
  const Keyframe back = from_msg(to_msg(kf, OdometryFrames{}), nullptr);
  EXPECT_EQ(back.id, 7);
  EXPECT_TRUE(back.gravity_body.isApprox(kf.gravity_body, 1e-15));
  EXPECT_NEAR(back.gravity_sigma_rad, 0.0004, 1e-9);
}

TEST(LcmConversions, NonFinitePointsAreDroppedAndCounted) {
  LidarScan scan;
  scan.points.resize(4);
  scan.points[1].position_m.x() = kNaN;
  scan.points[2].time_offset_s = std::numeric_limits<float>::infinity();
  size_t dropped = 0;
  EXPECT_EQ(from_msg(to_msg(scan, "r", "lidar", "m"), &dropped).points.size(), 2u);
  EXPECT_EQ(dropped, 2u);

  PointCloud cloud;
  cloud.push_back(Eigen::Vector3f(1, 2, 3), 1.0f);
  cloud.push_back(Eigen::Vector3f(kNaN, 2, 3), 1.0f);
  cloud.push_back(Eigen::Vector3f(4, 5, 6), kNaN);  // a bad intensity only zeroes it
  const PointCloud back = from_msg(to_msg(cloud), &dropped);
  EXPECT_EQ(dropped, 1u);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back.intensities[1], 0.0f);
}

TEST(LcmConversions, ImuBatchRoundTripDropsNonFiniteSamples) {
  std::vector<ImuSample> samples(3);
  for (int i = 0; i < 3; ++i) {
    samples[i].utime_us = 1000 + i;
    samples[i].accel_mps2 = Eigen::Vector3d(0, 0, 9.8 + i);
    samples[i].gyro_rps = Eigen::Vector3d(0.1 * i, 0, 0);
  }
  samples[1].gyro_rps.y() = std::nan("");
  const liloc::imu_t msg = to_msg(samples, "r", "imu");
  EXPECT_EQ(msg.header.utime, 1002);
  size_t dropped = 0;
  const std::vector<ImuSample> back = from_msg(msg, &dropped);
  EXPECT_EQ(dropped, 1u);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[1].utime_us, 1002);
  EXPECT_EQ(back[1].accel_mps2.z(), 11.8);
}

// compact_cloud_t carries a CompactCloud as it is; one that does not check out is refused.
TEST(LcmConversions, CompactCloudRoundTripAndBadMessages) {
  PointCloud cloud;
  cloud.push_back(Eigen::Vector3f(12.3456f, -98.7654f, 0.0049f), 7.0f);
  cloud.push_back(Eigen::Vector3f(-0.001f, 250.0f, -3.2f), 100.0f);
  const CompactCloud compact = quantize(cloud);
  const liloc::compact_cloud_t msg = to_msg(compact);
  EXPECT_EQ(msg.num_points, 2);
  const CompactCloud back = from_msg(msg);
  EXPECT_EQ(back.resolution_m, compact.resolution_m);
  EXPECT_EQ(back.intensity_scale, compact.intensity_scale);
  EXPECT_EQ(back.x, compact.x);
  EXPECT_EQ(back.y, compact.y);
  EXPECT_EQ(back.z, compact.z);
  EXPECT_EQ(back.intensity, compact.intensity);
  liloc::compact_cloud_t bad = msg;
  bad.resolution_m = 0.0f;
  EXPECT_THROW(from_msg(bad), std::invalid_argument);
  bad = msg;
  bad.y.pop_back();
  EXPECT_THROW(from_msg(bad), std::invalid_argument);
  bad = msg;
  bad.num_points = 1;  // arrays of 2
  EXPECT_THROW(from_msg(bad), std::invalid_argument);
}

TEST(MapConversions, SubmapRequestRoundTripKeepsTheReplyUrl) {
  SubmapQuery q;
  q.robot_id = "r3";
  q.request_id = 42;
  q.by_id = true;
  q.submap_ids = {4, 9};
  q.max_submaps = 2;
  q.include_clouds = true;
  q.reply_url = "udpm://239.255.76.67:7700?ttl=0";
  const SubmapQuery back = from_msg(to_msg(q, 1000));
  EXPECT_EQ(back.robot_id, "r3");
  EXPECT_EQ(back.request_id, 42);
  EXPECT_TRUE(back.by_id);
  EXPECT_EQ(back.submap_ids, q.submap_ids);
  EXPECT_EQ(back.max_submaps, 2);
  EXPECT_TRUE(back.include_clouds);
  EXPECT_EQ(back.reply_url, q.reply_url);
  q.by_id = false;
  q.position.x() = std::nan("");
  EXPECT_THROW(from_msg(to_msg(q, 1000)), std::invalid_argument);
}

// A reply part carries whole keyframes with their clouds; the offsets split them again.
TEST(MapConversions, SubmapReplyRoundTripSplitsTheCloudsByKeyframe) {
  SubmapReplyPart part;
  part.robot_id = "r1";
  part.request_id = 7;
  part.reply_count = 1;
  part.submap = Submap{};
  part.submap->id = 3;
  part.submap->keyframe_ids = {10, 11};
  KeyframeClouds clouds;
  for (int k = 0; k < 2; ++k) {
    MapKeyframe kf;
    kf.id = 10 + k;
    kf.T_map_body.translation() = Eigen::Vector3d(k, 2, 0);
    part.keyframes.push_back(kf);
    auto cloud = std::make_shared<PointCloud>();
    for (int i = 0; i < 3 + k; ++i) {
      cloud->push_back(Eigen::Vector3f(i, k, 1), static_cast<float>(i));
    }
    clouds.push_back(cloud);
  }
  part.clouds = deduplicate_submap_clouds(part.keyframes, clouds, 0.0);
  liloc::submap_t msg = to_msg(part, 5);
  const SubmapReplyPart back = from_msg(msg);
  ASSERT_TRUE(back.submap);
  EXPECT_EQ(back.submap->id, 3);
  ASSERT_EQ(back.keyframes.size(), 2u);
  ASSERT_TRUE(back.clouds);
  ASSERT_EQ(back.clouds->keyframes(), 2u);
  EXPECT_EQ(back.keyframes[1].id, 11);
  EXPECT_TRUE(back.keyframes[1].T_map_body.isApprox(part.keyframes[1].T_map_body));
  for (size_t k = 0; k < 2; ++k) {
    const PointCloud cloud = back.clouds->keyframe_cloud(k);
    ASSERT_EQ(cloud.size(), clouds[k]->size());
    for (size_t i = 0; i < cloud.size(); ++i) {
      EXPECT_LT((cloud.points[i] - clouds[k]->points[i]).norm(), 0.01);
      EXPECT_NEAR(cloud.intensities[i], clouds[k]->intensities[i], 0.01);
    }
  }
  msg.cloud_offsets[1] = 99;  // beyond the cloud
  EXPECT_THROW(from_msg(msg), std::invalid_argument);
  msg.cloud_offsets[1] = -1;
  EXPECT_THROW(from_msg(msg), std::invalid_argument);
  msg.cloud_offsets = {1, 3};  // point 0 would belong to no keyframe
  EXPECT_THROW(from_msg(msg), std::invalid_argument);

  // Clouds asked for but without points come back as clouds; none asked for, as none.
  SubmapReplyPart empty = part;
  empty.clouds = deduplicate_submap_clouds(
      part.keyframes, {std::make_shared<PointCloud>(), std::make_shared<PointCloud>()}, 0.0);
  const SubmapReplyPart empty_back = from_msg(to_msg(empty, 5));
  ASSERT_TRUE(empty_back.clouds);
  EXPECT_EQ(empty_back.clouds->keyframes(), 2u);
  EXPECT_TRUE(empty_back.clouds->cloud.empty());
  empty.clouds.reset();
  EXPECT_FALSE(from_msg(to_msg(empty, 5)).clouds);
  part.keyframes.pop_back();  // clouds of two keyframes for one
  EXPECT_THROW(to_msg(part, 5), std::invalid_argument);
}

TEST(PclConversions, RoundTripAndInvalidPoints) {
  PointCloud cloud;
  cloud.push_back(Eigen::Vector3f(1, 2, 3), 4.0f);
  cloud.push_back(Eigen::Vector3f(-1, 0, 2), 8.0f);
  pcl::PointCloud<pcl::PointXYZI> pcl_cloud = to_pcl(cloud);
  ASSERT_EQ(pcl_cloud.size(), 2u);
  EXPECT_EQ(pcl_cloud[1].intensity, 8.0f);
  pcl::PointXYZI invalid;
  invalid.x = invalid.y = invalid.z = kNaN;
  pcl_cloud.push_back(invalid);
  const PointCloud back = from_pcl(pcl_cloud);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back.points[0], cloud.points[0]);
}

TEST(SensorStream, LogsSamplesAndSweepsAsLiveIngestWould) {
  const std::string path = ::testing::TempDir() + "liloc_sensor_stream.lcmlog";
  {
    transport::LogWriter log(path);
    SensorStreamConfig config;
    config.robot_id = "r2";
    SensorStreamWriter writer(log, config);
    ImuSample imu;
    imu.utime_us = 1000000;
    writer.write_imu(imu);
    LidarScan scan;
    scan.utime_us = 1000000;
    scan.scan_period_s = 0.1f;
    scan.points.resize(3);
    writer.write_scan(scan);
    imu.utime_us = 1005000;
    writer.write_imu(imu);
    EXPECT_EQ(writer.imu_written(), 2);
    EXPECT_EQ(writer.scans_written(), 1);
  }
  transport::LogReader reader(path);
  transport::LogEventView event;
  ASSERT_TRUE(reader.next(event));
  EXPECT_EQ(event.channel, "r2.IMU");
  ASSERT_TRUE(reader.next(event));
  EXPECT_EQ(event.channel, "r2.LIDAR");
  EXPECT_EQ(event.utime, 1100000);  // available at the end of the sweep
  liloc::lidar_scan_t scan;
  ASSERT_TRUE(transport::decode(event, scan));
  EXPECT_EQ(scan.header.utime, 1000000);
  EXPECT_EQ(scan.num_points, 3);
  ASSERT_TRUE(reader.next(event));
  liloc::imu_t imu;
  ASSERT_TRUE(transport::decode(event, imu));
  EXPECT_EQ(imu.header.seq, 1);
  std::remove(path.c_str());
}

}  // namespace
}  // namespace liloc::bridge
