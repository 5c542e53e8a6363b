#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>

#include "dataset/dataset_error.hpp"
#include "dataset/folder_dataset_reader.hpp"
#include "dataset/kitti_odometry_reader.hpp"
#include "dataset/nclt_reader.hpp"
#include "dataset/tum_trajectory.hpp"
#include "math/se3.hpp"
#include "math/so3.hpp"

namespace liloc {
namespace {

std::string temp_file(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}

std::string error_of(const std::string& text) {
  const std::string path = temp_file("liloc_bad.tum", text);
  try {
    read_tum(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(TumTrajectory, WriteThenReadIsExact) {
  std::vector<StampedPose> poses;
  for (int i = 0; i < 20; ++i) {
    poses.push_back(
        {1700000000.0 + 0.1 * i, se3::make(so3::exp(Eigen::Vector3d(0.01 * i, -0.02 * i, 0.3 * i)),
                                           Eigen::Vector3d(i, -2.0 * i, 0.5))});
  }
  const std::string path = ::testing::TempDir() + "liloc_roundtrip.tum";
  write_tum(path, Trajectory(poses));
  const Trajectory back = read_tum(path);
  ASSERT_EQ(back.size(), poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_NEAR(back.poses()[i].time_s, poses[i].time_s, 1e-6);
    EXPECT_TRUE(back.poses()[i].T.isApprox(poses[i].T, 1e-8));
  }
  std::remove(path.c_str());
}

TEST(TumTrajectory, SkipsCommentsAndBlankLines) {
  const std::string path = temp_file(
      "liloc_comments.tum", "# header\n\n1.0 0 0 0 0 0 0 1\n  # indented\n2.0 1 0 0 0 0 0 1\n");
  EXPECT_EQ(read_tum(path).size(), 2u);
}

TEST(TumTrajectory, ErrorsNameFileAndLine) {
  std::string e = error_of("1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 1\n");
  EXPECT_NE(e.find("liloc_bad.tum:2"), std::string::npos) << e;
  EXPECT_NE(e.find("expected 8 numbers"), std::string::npos) << e;
  e = error_of("1.0 0 0 nan 0 0 0 1\n");
  EXPECT_NE(e.find(":1: non-finite"), std::string::npos) << e;
  e = error_of("1.0 0 0 0 0 0 0 2\n");
  EXPECT_NE(e.find("quaternion norm"), std::string::npos) << e;
  e = error_of("1.0 0 0 0 0 0 0 1 9\n");
  EXPECT_NE(e.find("more than 8 fields"), std::string::npos) << e;
  e = error_of("1.0 0 0 0 0 0 0 1\n1.0 0 0 0 0 0 0 1\n");
  EXPECT_NE(e.find("two poses at time"), std::string::npos) << e;
  EXPECT_THROW(read_tum("/nonexistent.tum"), std::runtime_error);
}

// ---------------------------------------------------------------------------------------
// Real-dataset readers. Each test writes a small dataset in the real on-disk format.

namespace fs = std::filesystem;
using dataset::DatasetError;
using dataset::SensorEvent;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// A fresh, empty folder under the test temp dir.
std::string fresh_dir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("liloc_dataset_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

void write_file(const std::string& path, const std::string& bytes) {
  fs::create_directories(fs::path(path).parent_path());
  std::ofstream(path, std::ios::binary) << bytes;
}

template <class T>
void append(std::string& bytes, T value) {
  bytes.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

std::vector<SensorEvent> read_all(dataset::SensorDatasetReader& reader) {
  std::vector<SensorEvent> events;
  for (SensorEvent event; reader.next(event);) {
    events.push_back(event);
  }
  return events;
}

std::vector<LidarScan> scans_of(const std::vector<SensorEvent>& events) {
  std::vector<LidarScan> scans;
  for (const SensorEvent& e : events) {
    if (const auto* scan = std::get_if<LidarScan>(&e)) {
      scans.push_back(*scan);
    }
  }
  return scans;
}

std::vector<ImuSample> imu_of(const std::vector<SensorEvent>& events) {
  std::vector<ImuSample> samples;
  for (const SensorEvent& e : events) {
    if (const auto* sample = std::get_if<ImuSample>(&e)) {
      samples.push_back(*sample);
    }
  }
  return samples;
}

void expect_time_ordered(const std::vector<SensorEvent>& events) {
  for (size_t i = 1; i < events.size(); ++i) {
    EXPECT_LE(dataset::available_utime_us(events[i - 1]), dataset::available_utime_us(events[i]))
        << "event " << i;
  }
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const DatasetError& e) {
    return e.what();
  }
  return "";
}

// ---- KITTI ----------------------------------------------------------------------------

// Camera x right, y down, z forward; velodyne x forward, y left, z up.
Eigen::Isometry3d kitti_T_cam_velo() {
  Eigen::Matrix3d R;
  R << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  return se3::make(R, Eigen::Vector3d(0.1, -0.2, -0.3));
}

std::string row_3x4(const Eigen::Isometry3d& T) {
  std::string out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) {
      out += (out.empty() ? "" : " ") + std::to_string(T.matrix()(r, c));
    }
  }
  return out;
}

std::string kitti_points(const std::vector<std::array<float, 4>>& points) {
  std::string bytes;
  for (const auto& p : points) {
    for (float v : p) {
      append(bytes, v);
    }
  }
  return bytes;
}

// sequences/00 with three scans 0.1036 s apart.
std::string write_kitti(const std::string& name) {
  const std::string root = fresh_dir(name);
  const std::string seq = root + "/sequences/00";
  write_file(seq + "/times.txt", "0.000000e+00\n1.036000e-01\n2.072000e-01\n");
  write_file(seq + "/calib.txt",
             "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nTr: " + row_3x4(kitti_T_cam_velo()) + "\n");
  write_file(seq + "/velodyne/000000.bin",
             kitti_points({{1, 0, 0, 0.5f}, {0, 2, 0, 0.25f}, {-3, 0, 1, 1}, {kNaN, 0, 0, 0}}));
  write_file(seq + "/velodyne/000001.bin", kitti_points({{5, 5, 0, 0.1f}}));
  write_file(seq + "/velodyne/000002.bin", kitti_points({{6, 6, 0, 0.2f}}));
  return root;
}

TEST(KittiOdometryReader, StampsEveryPointAtTheFrameTimeByDefault) {
  dataset::KittiOdometryReader reader(write_kitti("kitti_frame"), "00");
  const std::vector<SensorEvent> events = read_all(reader);
  const std::vector<LidarScan> scans = scans_of(events);
  ASSERT_EQ(scans.size(), 3u);
  EXPECT_TRUE(imu_of(events).empty());
  expect_time_ordered(events);
  // The frame time is mid-sweep: the sweep starts half a period earlier.
  EXPECT_EQ(scans[0].utime_us, 950000);
  EXPECT_EQ(scans[1].utime_us, 1053600);
  EXPECT_FLOAT_EQ(scans[0].scan_period_s, 0.1f);
  ASSERT_EQ(scans[0].points.size(), 3u);
  EXPECT_EQ(scans[0].points[1].position_m, Eigen::Vector3f(0, 2, 0));
  EXPECT_FLOAT_EQ(scans[0].points[1].intensity, 0.25f);
  for (const LidarPoint& p : scans[0].points) {
    EXPECT_FLOAT_EQ(p.time_offset_s, 0.05f);
    EXPECT_EQ(p.ring, 0);
  }
  EXPECT_EQ(reader.stats().dropped_non_finite_points, 1);
  EXPECT_EQ(reader.stats().scans, 3);
  EXPECT_EQ(reader.stats().points, 5);
  EXPECT_DOUBLE_EQ(*reader.progress(), 1.0);
  const dataset::SensorSetup setup = reader.sensor_setup();
  EXPECT_EQ(setup.sensor_model, "hdl64");
  EXPECT_FALSE(setup.has_imu);
  EXPECT_TRUE(setup.T_body_lidar->isApprox(Eigen::Isometry3d::Identity()));
}

TEST(KittiOdometryReader, AzimuthTimesStartBehindAndTurnClockwise) {
  const std::string root = write_kitti("kitti_azimuth");
  write_file(
      root + "/sequences/00/velodyne/000000.bin",
      kitti_points({{-1, 0, 0, 0}, {0, 1, 0, 0}, {1, 0, 0, 0}, {0, -1, 0, 0}, {-1, -1e-6f, 0, 0}}));
  dataset::KittiConfig config;
  config.point_time = "azimuth";
  dataset::KittiOdometryReader reader(root, "00", config);
  const LidarScan scan = scans_of(read_all(reader)).front();
  ASSERT_EQ(scan.points.size(), 5u);
  const float expected[] = {0.0f, 0.025f, 0.05f, 0.075f, 0.1f};  // behind, left, front, right
  for (size_t i = 0; i < 5; ++i) {
    EXPECT_NEAR(scan.points[i].time_offset_s, expected[i], 1e-6) << i;
  }
}

TEST(KittiOdometryReader, GroundTruthIsInTheVelodyneFrame) {
  const std::string root = write_kitti("kitti_gt");
  // Camera 2 m forward and turned by 0.3 rad about its y (down) axis, i.e. to the right.
  const Eigen::Isometry3d P1 =
      se3::make(so3::exp(Eigen::Vector3d(0, 0.3, 0)), Eigen::Vector3d(0, 0, 2));
  write_file(root + "/poses/00.txt", row_3x4(Eigen::Isometry3d::Identity()) + "\n" + row_3x4(P1) +
                                         "\n" + row_3x4(Eigen::Isometry3d::Identity()) + "\n");
  dataset::KittiOdometryReader reader(root, "00");
  const Trajectory gt = reader.ground_truth();
  ASSERT_EQ(gt.size(), 3u);
  EXPECT_DOUBLE_EQ(gt.poses()[1].time_s, 1.1036);
  const Eigen::Isometry3d& T = gt.poses()[1].T;
  // Turning right about the camera's down axis is a negative yaw about velodyne z.
  EXPECT_TRUE(T.linear().isApprox(so3::exp(Eigen::Vector3d(0, 0, -0.3)), 1e-5));
  const Eigen::Isometry3d expected = kitti_T_cam_velo().inverse() * P1 * kitti_T_cam_velo();
  EXPECT_TRUE(T.isApprox(expected, 1e-5));
  EXPECT_TRUE(gt.poses()[0].T.isApprox(Eigen::Isometry3d::Identity(), 1e-6));

  write_file(root + "/poses/00.txt", row_3x4(Eigen::Isometry3d::Identity()) + "\n");
  const std::string e = error_of([&] { reader.ground_truth(); });
  EXPECT_NE(e.find("poses/00.txt: 1 poses for 3 scan times"), std::string::npos) << e;
}

TEST(KittiOdometryReader, ErrorsNameFileAndOffsetOrLine) {
  std::string root = write_kitti("kitti_truncated");
  write_file(root + "/sequences/00/velodyne/000001.bin",
             kitti_points({{1, 2, 3, 4}, {5, 6, 7, 8}}) + "12345");
  std::string e = error_of([&] {
    dataset::KittiOdometryReader reader(root, "00");
    read_all(reader);
  });
  EXPECT_NE(e.find("000001.bin: byte 32: truncated point"), std::string::npos) << e;

  root = write_kitti("kitti_missing_scan");
  fs::remove(root + "/sequences/00/velodyne/000002.bin");
  e = error_of([&] {
    dataset::KittiOdometryReader reader(root, "00");
    read_all(reader);
  });
  EXPECT_NE(e.find("000002.bin: cannot open"), std::string::npos) << e;

  root = write_kitti("kitti_bad_times");
  write_file(root + "/sequences/00/times.txt", "0.0\n0.1 x\n");
  e = error_of([&] { dataset::KittiOdometryReader(root, "00"); });
  EXPECT_NE(e.find("times.txt:2: expected 1 fields, found 2"), std::string::npos) << e;
  write_file(root + "/sequences/00/times.txt", "0.0\nabc\n");
  e = error_of([&] { dataset::KittiOdometryReader(root, "00"); });
  EXPECT_NE(e.find("times.txt:2: field 1 'abc' is not a number"), std::string::npos) << e;

  write_file(root + "/sequences/00/times.txt", "0.0\n");
  write_file(root + "/sequences/00/calib.txt", "P0: 1 0 0 0 0 1 0 0 0 0 1 0\n");
  e = error_of([&] { dataset::KittiOdometryReader(root, "00"); });
  EXPECT_NE(e.find("calib.txt: no 'Tr:' line"), std::string::npos) << e;

  e = error_of([&] { dataset::KittiOdometryReader(root, "07"); });
  EXPECT_NE(e.find("sequences/07/times.txt: cannot open"), std::string::npos) << e;
}

// ---- NCLT -----------------------------------------------------------------------------

constexpr int64_t kNcltStartUtime = 1326030000000000;  // 2012-01-08

struct NcltHit {
  Eigen::Vector3d position_m;  // in NCLT's hits frame (z down)
  uint8_t intensity = 0;
  uint8_t laser_id = 0;
};

std::string nclt_packet(int64_t utime, const std::vector<NcltHit>& hits) {
  std::string bytes;
  for (int i = 0; i < 4; ++i) {
    append<uint16_t>(bytes, 44444);
  }
  append<uint32_t>(bytes, static_cast<uint32_t>(hits.size()));
  append<uint64_t>(bytes, static_cast<uint64_t>(utime));
  append<uint32_t>(bytes, 0);
  for (const NcltHit& h : hits) {
    for (int a = 0; a < 3; ++a) {
      append<uint16_t>(bytes,
                       static_cast<uint16_t>(std::lround((h.position_m[a] + 100.0) / 0.005)));
    }
    append<uint8_t>(bytes, h.intensity);
    append<uint8_t>(bytes, h.laser_id);
  }
  return bytes;
}

// A point at azimuth azimuth_deg in the z-up lidar frame, written in the z-down hits frame.
Eigen::Vector3d nclt_hits_frame(double range_m, double azimuth_deg, double z_up_m) {
  const double a = azimuth_deg * M_PI / 180.0;
  return Eigen::Vector3d(range_m * std::cos(a), -range_m * std::sin(a), -z_up_m);
}

// 60 packets 5 ms apart of a sensor spinning clockwise at 10 Hz (18 deg per packet),
// starting at azimuth 81 deg: the 180 deg cut falls between packets 14/15, 34/35, 54/55.
std::string nclt_spinning_hits() {
  std::string bytes;
  for (int k = 0; k < 60; ++k) {
    const double azimuth = 81.0 - 18.0 * k;
    std::vector<NcltHit> hits = {{nclt_hits_frame(10, azimuth, -1), static_cast<uint8_t>(k), 0},
                                 {nclt_hits_frame(20, azimuth, 2), static_cast<uint8_t>(k), 1}};
    if (k == 31) {
      // A return off the robot itself: its azimuth says "past the cut", its range says
      // not to trust it.
      hits.push_back({nclt_hits_frame(0.3, 120, 0), 0, 31});
    }
    bytes += nclt_packet(kNcltStartUtime + 5000 * k, hits);
  }
  return bytes;
}

std::string ms25_row(int64_t utime, double ax, double ay, double az, double gx, double gy,
                     double gz) {
  return std::to_string(utime) + ",0.1,0.2,0.3," + std::to_string(ax) + "," + std::to_string(ay) +
         "," + std::to_string(az) + "," + std::to_string(gx) + "," + std::to_string(gy) + "," +
         std::to_string(gz) + "\n";
}

std::string write_nclt(const std::string& name) {
  const std::string root = fresh_dir(name);
  const std::string session = root + "/2012-01-08";
  write_file(session + "/velodyne_hits.bin", nclt_spinning_hits());
  std::string imu;
  for (int64_t t = kNcltStartUtime; t <= kNcltStartUtime + 300000; t += 10000) {
    imu += ms25_row(t, 0.1, 0.2, -9.8, 0.01, 0.02, 0.03);
    if (t == kNcltStartUtime + 90000) {
      imu += ms25_row(t, 0, 0, 0, 0, 0, 0);  // repeated time: dropped
    }
  }
  write_file(session + "/ms25.csv", imu);
  write_file(root + "/groundtruth_2012-01-08.csv",
             std::to_string(kNcltStartUtime) + ",10,5,-2,0,0,1.5707963267948966\n" +
                 std::to_string(kNcltStartUtime + 50000) + ",nan,nan,nan,nan,nan,nan\n" +
                 std::to_string(kNcltStartUtime) + ",10,5,-2,0,0,0\n" +
                 std::to_string(kNcltStartUtime + 100000) + ",11,5,-2,0.1,0.2,1.5\n");
  return session;
}

TEST(NcltReader, SplitsSweepsAtTheAzimuthCrossingWithPacketTimes) {
  dataset::NcltReader reader(write_nclt("nclt_sweeps"));
  const std::vector<SensorEvent> events = read_all(reader);
  expect_time_ordered(events);
  const std::vector<LidarScan> scans = scans_of(events);
  ASSERT_EQ(scans.size(), 4u);
  // Packets 0-14 (the sweep in progress when the file starts), 15-34, 35-54, 55-59.
  const int first_packet[] = {0, 15, 35, 55};
  const int packet_count[] = {15, 20, 20, 5};
  for (size_t s = 0; s < 4; ++s) {
    EXPECT_EQ(scans[s].utime_us, kNcltStartUtime + 5000 * first_packet[s]) << s;
    EXPECT_NEAR(scans[s].scan_period_s, 0.005 * (packet_count[s] - 1), 1e-6) << s;
  }
  EXPECT_EQ(scans[1].points.size(), 41u);  // 2 hits per packet + the close return
  EXPECT_EQ(reader.stats().scans_cut_by_time, 0);

  // Per-point time is the packet's; decoded, turned z-up, rings in elevation order.
  const LidarScan& sweep = scans[1];
  for (const LidarPoint& p : sweep.points) {
    const int packet = p.intensity;
    if (p.ring == 31) {
      continue;  // the close return
    }
    EXPECT_NEAR(p.time_offset_s, 0.005 * (packet - 15), 1e-6);
    const double a = (81.0 - 18.0 * packet) * M_PI / 180.0;
    const double range = p.ring == 0 ? 10 : 20;
    const Eigen::Vector3f expected(static_cast<float>(range * std::cos(a)),
                                   static_cast<float>(range * std::sin(a)), p.ring == 0 ? -1 : 2);
    EXPECT_LT((p.position_m - expected).norm(), 0.005f) << p.position_m.transpose();
  }
  EXPECT_EQ(sweep.points[0].ring, 0);   // laser 0: -30.67 deg, the lowest
  EXPECT_EQ(sweep.points[1].ring, 16);  // laser 1: -9.33 deg, above the 16 even lasers

  dataset::NcltConfig raw_ids;
  raw_ids.laser_id_is_firing_order = false;
  dataset::NcltReader raw_reader(write_nclt("nclt_raw_ids"), raw_ids);
  EXPECT_EQ(scans_of(read_all(raw_reader))[1].points[1].ring, 1);
}

TEST(NcltReader, ImuIsTurnedZUpAndMergedInTimeOrder) {
  dataset::NcltReader reader(write_nclt("nclt_imu"));
  const std::vector<SensorEvent> events = read_all(reader);
  const std::vector<ImuSample> imu = imu_of(events);
  ASSERT_EQ(imu.size(), 31u);
  EXPECT_EQ(reader.stats().dropped_imu_samples_not_increasing, 1);
  EXPECT_EQ(imu[0].utime_us, kNcltStartUtime);
  // At rest the MS25 (z down) measures -g on z; liloc's body frame is z up.
  EXPECT_TRUE(imu[0].accel_mps2.isApprox(Eigen::Vector3d(0.1, -0.2, 9.8)));
  EXPECT_TRUE(imu[0].gyro_rps.isApprox(Eigen::Vector3d(0.01, -0.02, -0.03)));
  // The first sweep ends at packet 14 (70 ms): the samples up to it come before it.
  size_t first_scan = 0;
  while (std::holds_alternative<ImuSample>(events[first_scan])) {
    ++first_scan;
  }
  // Samples at 0, 10, ..., 70 ms: the one at the sweep's end comes before the sweep.
  EXPECT_EQ(first_scan, 8u);
  EXPECT_EQ(std::get<ImuSample>(events[7]).utime_us, kNcltStartUtime + 70000);
  EXPECT_TRUE(reader.sensor_setup().has_imu);
}

TEST(NcltReader, GroundTruthAndExtrinsicsAreInLilocsZUpFrames) {
  dataset::NcltReader reader(write_nclt("nclt_gt"));
  const Trajectory gt = reader.ground_truth();
  ASSERT_EQ(gt.size(), 2u);
  EXPECT_EQ(reader.stats().dropped_ground_truth_rows, 2);  // the NaN row, the repeated time
  EXPECT_DOUBLE_EQ(gt.poses()[0].time_s, kNcltStartUtime * 1e-6);
  // Body at (10 N, 5 E, 2 m up) heading east; the MS25 sits at (-0.11, -0.18, -0.71) in
  // the body frame (behind, left, above). East is -y in liloc's north-west-up world.
  const Eigen::Isometry3d& T = gt.poses()[0].T;
  EXPECT_TRUE(T.translation().isApprox(Eigen::Vector3d(10.18, -4.89, 2.71), 1e-9))
      << T.translation().transpose();
  EXPECT_TRUE(T.linear().isApprox(so3::exp(Eigen::Vector3d(0, 0, -M_PI / 2)), 1e-9));

  const dataset::SensorSetup setup = reader.sensor_setup();
  EXPECT_EQ(setup.sensor_model, "hdl32");
  // Hits in the body frame: the lidar frame sits at the body origin, 0.71 m below the IMU.
  EXPECT_TRUE(setup.T_body_lidar->translation().isApprox(Eigen::Vector3d(0.11, -0.18, -0.71)));
  EXPECT_TRUE(setup.T_body_lidar->linear().isIdentity(1e-12));

  dataset::NcltConfig sensor_frame;
  sensor_frame.x_body_hits = {0.002, -0.004, -0.957, 0.807, 0.166, -90.703};
  const Eigen::Isometry3d T_body_lidar =
      *dataset::NcltReader(write_nclt("nclt_sensor_frame"), sensor_frame)
           .sensor_setup()
           .T_body_lidar;
  EXPECT_TRUE(T_body_lidar.translation().isApprox(Eigen::Vector3d(0.112, -0.176, 0.247), 1e-9));
  // NCLT's -90.7 deg yaw about z-down is +90.7 deg about z-up.
  EXPECT_NEAR(so3::log(T_body_lidar.linear()).z(), 90.703 * M_PI / 180.0, 0.01);
}

TEST(NcltReader, FallsBackToTheNominalPeriodWithoutAzimuthCrossings) {
  const std::string session = fresh_dir("nclt_fallback");
  std::string bytes;
  for (int k = 0; k < 60; ++k) {
    bytes += nclt_packet(kNcltStartUtime + 5000 * k, {{nclt_hits_frame(10, 30, 0), 0, 0}});
  }
  write_file(session + "/velodyne_hits.bin", bytes);
  dataset::NcltReader reader(session);
  const std::vector<LidarScan> scans = scans_of(read_all(reader));
  ASSERT_EQ(scans.size(), 3u);
  for (size_t s = 0; s < 3; ++s) {
    EXPECT_EQ(scans[s].utime_us, kNcltStartUtime + 100000 * static_cast<int64_t>(s));
    EXPECT_EQ(scans[s].points.size(), 20u);
  }
  EXPECT_EQ(reader.stats().scans_cut_by_time, 2);
  EXPECT_FALSE(reader.sensor_setup().has_imu);
  EXPECT_TRUE(reader.ground_truth().empty());
}

TEST(NcltReader, DropsPacketsThatGoBackInTime) {
  const std::string session = fresh_dir("nclt_backwards");
  const NcltHit hit{nclt_hits_frame(10, 30, 0), 0, 0};
  write_file(session + "/velodyne_hits.bin", nclt_packet(kNcltStartUtime, {hit}) +
                                                 nclt_packet(kNcltStartUtime - 1000, {hit}) +
                                                 nclt_packet(kNcltStartUtime + 1000, {hit}));
  dataset::NcltReader reader(session);
  const std::vector<LidarScan> scans = scans_of(read_all(reader));
  ASSERT_EQ(scans.size(), 1u);
  EXPECT_EQ(scans[0].points.size(), 2u);
  EXPECT_EQ(reader.stats().dropped_lidar_packets_not_increasing, 1);
}

TEST(NcltReader, ErrorsNameFileAndOffsetOrLine) {
  const std::string session = fresh_dir("nclt_errors");
  const std::string hits_path = session + "/velodyne_hits.bin";
  const NcltHit hit{nclt_hits_frame(10, 30, 0), 7, 3};
  const std::string packet = nclt_packet(kNcltStartUtime, {hit, hit});  // 24 + 16 bytes
  const auto error_reading = [&] {
    return error_of([&] {
      dataset::NcltReader reader(session);
      read_all(reader);
    });
  };

  std::string corrupt = packet + packet;
  corrupt[40 + 2] = 0;  // the second packet's magic
  write_file(hits_path, corrupt);
  std::string e = error_reading();
  EXPECT_NE(e.find("velodyne_hits.bin: byte 40: bad packet magic"), std::string::npos) << e;

  write_file(hits_path, packet + packet.substr(0, 30));
  e = error_reading();
  EXPECT_NE(e.find("velodyne_hits.bin: byte 64: truncated packet: the header at byte 40 "
                   "declares 2 hits (16 bytes), only 6 remain"),
            std::string::npos)
      << e;

  write_file(hits_path, packet + packet.substr(0, 10));
  e = error_reading();
  EXPECT_NE(e.find("byte 40: truncated packet header (10 of 24 bytes)"), std::string::npos) << e;

  std::string bad_laser = packet;
  bad_laser[24 + 8 + 7] = 40;  // the second hit's laser id
  write_file(hits_path, bad_laser);
  e = error_reading();
  EXPECT_NE(e.find("byte 39: laser id 40 is not an HDL-32E laser"), std::string::npos) << e;

  write_file(hits_path, packet);
  write_file(session + "/ms25.csv", ms25_row(kNcltStartUtime, 0, 0, -9.8, 0, 0, 0) + "\n" +
                                        std::to_string(kNcltStartUtime + 10000) +
                                        ",1,2,3,4,5,6,7,8\n");
  e = error_reading();
  EXPECT_NE(e.find("ms25.csv:3: expected 10 fields, found 9"), std::string::npos) << e;

  e = error_of([&] { dataset::NcltReader(session + "/missing"); });
  EXPECT_NE(e.find("missing/velodyne_hits.bin: cannot open"), std::string::npos) << e;
}

// ---- PCD folder -----------------------------------------------------------------------

std::string pcd_header(const std::string& fields, const std::string& sizes,
                       const std::string& types, size_t points, const std::string& data) {
  std::string counts = "1";
  for (char c : fields) {
    counts += c == ' ' ? " 1" : "";
  }
  return "# .PCD v0.7\nVERSION 0.7\nFIELDS " + fields + "\nSIZE " + sizes + "\nTYPE " + types +
         "\nCOUNT " + counts + "\nWIDTH " + std::to_string(points) +
         "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + std::to_string(points) + "\nDATA " +
         data + "\n";
}

// Binary x y z intensity (float32), three points, one of them NaN.
std::string binary_xyzi_pcd() {
  std::string bytes = pcd_header("x y z intensity", "4 4 4 4", "F F F F", 3, "binary");
  for (float v : {1.0f, 2.0f, 3.0f, 10.0f, kNaN, 0.0f, 0.0f, 0.0f, 4.0f, 5.0f, 6.0f, 20.0f}) {
    append(bytes, v);
  }
  return bytes;
}

std::string write_folder(const std::string& name) {
  const std::string folder = fresh_dir(name);
  // Seconds in the name; relative times in seconds; rings.
  write_file(folder + "/scans/1700000000.000000.pcd",
             pcd_header("x y z intensity t ring", "4 4 4 4 4 2", "F F F F F U", 3, "ascii") +
                 "1 0 0 5 0.0 3\n0 1 0 6 0.04 7\n0 0 1 7 0.09 15\n");
  // Nanoseconds in the name, no time field.
  write_file(folder + "/scans/1700000000100000000.pcd", binary_xyzi_pcd());
  write_file(folder + "/imu.csv",
             "time_s, ax, ay, az, gx, gy, gz\n"
             "1699999999.99,0,0,9.81,0.1,0.2,0.3\n"
             "1700000000.05,0,0,9.81,0.1,0.2,0.3\n"
             "1700000000.05,1,1,1,1,1,1\n"
             "1700000000.15,0,0,9.81,0.1,0.2,0.3\n"
             "1700000000.25,0,0,9.81,0.1,0.2,0.3\n");
  write_file(folder + "/ground_truth.tum",
             "1700000000.0 0 0 0 0 0 0 1\n1700000000.1 1 0 0 0 0 0 1\n");
  return folder;
}

TEST(FolderDatasetReader, ReadsPcdScansImuAndGroundTruthInTimeOrder) {
  dataset::FolderDatasetReader reader(write_folder("folder"));
  const std::vector<SensorEvent> events = read_all(reader);
  expect_time_ordered(events);
  const std::vector<LidarScan> scans = scans_of(events);
  ASSERT_EQ(scans.size(), 2u);
  EXPECT_EQ(scans[0].utime_us, 1700000000000000);
  EXPECT_FLOAT_EQ(scans[0].scan_period_s, 0.1f);
  ASSERT_EQ(scans[0].points.size(), 3u);
  EXPECT_FLOAT_EQ(scans[0].points[1].time_offset_s, 0.04f);
  EXPECT_FLOAT_EQ(scans[0].points[2].intensity, 7.0f);
  EXPECT_EQ(scans[0].points[2].ring, 15);
  EXPECT_EQ(scans[0].points[2].position_m, Eigen::Vector3f(0, 0, 1));

  EXPECT_EQ(scans[1].utime_us, 1700000000100000);
  ASSERT_EQ(scans[1].points.size(), 2u);  // the NaN point is dropped
  EXPECT_EQ(scans[1].points[1].position_m, Eigen::Vector3f(4, 5, 6));
  EXPECT_FLOAT_EQ(scans[1].points[1].intensity, 20.0f);
  EXPECT_FLOAT_EQ(scans[1].points[1].time_offset_s, 0.0f);
  EXPECT_EQ(reader.stats().dropped_non_finite_points, 1);

  const std::vector<ImuSample> imu = imu_of(events);
  ASSERT_EQ(imu.size(), 4u);
  EXPECT_EQ(reader.stats().dropped_imu_samples_not_increasing, 1);
  EXPECT_EQ(imu[1].utime_us, 1700000000050000);
  EXPECT_TRUE(imu[1].accel_mps2.isApprox(Eigen::Vector3d(0, 0, 9.81)));
  EXPECT_TRUE(imu[1].gyro_rps.isApprox(Eigen::Vector3d(0.1, 0.2, 0.3)));
  // The first sweep ends at 0.1 s: after the 0.05 s sample, before the 0.15 s one.
  EXPECT_TRUE(std::holds_alternative<ImuSample>(events[1]));
  EXPECT_TRUE(std::holds_alternative<LidarScan>(events[2]));

  EXPECT_EQ(reader.ground_truth().size(), 2u);
  EXPECT_FALSE(reader.sensor_setup().T_body_lidar.has_value());
  EXPECT_TRUE(reader.sensor_setup().has_imu);
}

TEST(FolderDatasetReader, DetectsRelativeAbsoluteAndNanosecondPointTimes) {
  const std::string folder = fresh_dir("folder_times");
  // Absolute seconds (double): the sweep starts at its earliest point, not at the name.
  write_file(folder + "/scans/1700000000.5.pcd",
             pcd_header("x y z timestamp", "4 4 4 8", "F F F F", 2, "ascii") +
                 "1 0 0 1700000000.52\n2 0 0 1700000000.60\n");
  // Negative offsets (stamped at the sweep's end): the start moves back by the earliest.
  write_file(folder + "/scans/1700000001.0.pcd",
             pcd_header("x y z time", "4 4 4 4", "F F F F", 2, "ascii") + "1 0 0 -0.1\n2 0 0 0\n");
  // Ouster's uint32 nanosecond offsets.
  write_file(folder + "/scans/1700000002.0.pcd",
             pcd_header("x y z t", "4 4 4 4", "F F F U", 2, "ascii") + "1 0 0 0\n2 0 0 50000000\n");
  dataset::FolderDatasetReader reader(folder);
  const std::vector<LidarScan> scans = scans_of(read_all(reader));
  ASSERT_EQ(scans.size(), 3u);
  EXPECT_EQ(scans[0].utime_us, 1700000000520000);
  EXPECT_NEAR(scans[0].points[1].time_offset_s, 0.08, 1e-6);
  EXPECT_EQ(scans[1].utime_us, 1700000000900000);
  EXPECT_NEAR(scans[1].points[0].time_offset_s, 0.0, 1e-6);
  EXPECT_NEAR(scans[1].points[1].time_offset_s, 0.1, 1e-6);
  EXPECT_EQ(scans[2].utime_us, 1700000002000000);
  EXPECT_NEAR(scans[2].points[1].time_offset_s, 0.05, 1e-6);
  EXPECT_FALSE(reader.sensor_setup().has_imu);
  EXPECT_TRUE(reader.ground_truth().empty());
}

TEST(FolderDatasetReader, ErrorsNameFileAndOffsetOrLine) {
  const auto error_reading = [](const std::string& folder) {
    return error_of([&] {
      dataset::FolderDatasetReader reader(folder);
      read_all(reader);
    });
  };
  std::string folder = fresh_dir("folder_truncated");
  const std::string binary = binary_xyzi_pcd();
  write_file(folder + "/scans/1.0.pcd", binary.substr(0, binary.size() - 5));
  std::string e = error_reading(folder);
  const size_t data_start = binary.size() - 48;
  EXPECT_NE(e.find("1.0.pcd: byte " + std::to_string(binary.size() - 5) +
                   ": truncated: the header declares 3 points of 16 bytes from byte " +
                   std::to_string(data_start)),
            std::string::npos)
      << e;

  folder = fresh_dir("folder_bad_ascii");
  write_file(folder + "/scans/1.0.pcd",
             pcd_header("x y z", "4 4 4", "F F F", 3, "ascii") + "1 2 3\n4 abc 6\n7 8 9\n");
  e = error_reading(folder);
  EXPECT_NE(e.find("1.0.pcd:13: 'abc' is not a number"), std::string::npos) << e;
  write_file(folder + "/scans/1.0.pcd",
             pcd_header("x y z", "4 4 4", "F F F", 3, "ascii") + "1 2 3\n4 6\n");
  e = error_reading(folder);
  EXPECT_NE(e.find("1.0.pcd:13: expected 3 values, found 2"), std::string::npos) << e;
  write_file(folder + "/scans/1.0.pcd",
             pcd_header("x y z", "4 4 4", "F F F", 3, "ascii") + "1 2 3\n4 5 6\n");
  e = error_reading(folder);
  EXPECT_NE(e.find("1.0.pcd:14: truncated: the header declares 3 points, the data has 2"),
            std::string::npos)
      << e;
  std::string header = pcd_header("x y z", "4 4 4", "F F F", 1, "ascii");
  header.replace(header.find("TYPE"), 4, "TYPO");
  write_file(folder + "/scans/1.0.pcd", header + "1 2 3\n");
  e = error_reading(folder);
  EXPECT_NE(e.find("1.0.pcd:5: unknown PCD header keyword 'TYPO'"), std::string::npos) << e;
  write_file(folder + "/scans/1.0.pcd",
             pcd_header("a b c", "4 4 4", "F F F", 1, "ascii") + "1 2 3\n");
  e = error_reading(folder);
  EXPECT_NE(e.find("1.0.pcd: no x, y, z fields"), std::string::npos) << e;

  folder = fresh_dir("folder_bad_name");
  write_file(folder + "/scans/scan_a.pcd", binary);
  e = error_of([&] { dataset::FolderDatasetReader{folder}; });
  EXPECT_NE(e.find("scan_a.pcd: file name is not a time"), std::string::npos) << e;

  folder = fresh_dir("folder_bad_imu");
  write_file(folder + "/scans/1.0.pcd", binary);
  write_file(folder + "/imu.csv", "time,ax,ay,az,gx,gy,gz\n");
  e = error_of([&] { dataset::FolderDatasetReader{folder}; });
  EXPECT_NE(e.find("imu.csv:1: expected the header 'time_s,ax,ay,az,gx,gy,gz'"), std::string::npos)
      << e;
  write_file(folder + "/imu.csv", "time_s,ax,ay,az,gx,gy,gz\n0.5,0,0,9.8,0,0,0\n0.6,0,0,9.8,0,0\n");
  e = error_reading(folder);
  EXPECT_NE(e.find("imu.csv:3: expected 7 fields, found 6"), std::string::npos) << e;

  e = error_of([&] { dataset::FolderDatasetReader{fresh_dir("folder_empty")}; });
  EXPECT_NE(e.find("folder_empty/scans: no such folder"), std::string::npos) << e;
}

}  // namespace
}  // namespace liloc
