#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "bridge/lcm_conversions.hpp"
#include "ingest_node/ingest_node.hpp"

namespace liloc {
namespace {

// A dataset of `scans` sweeps of 0.1 s, 3 points each, and an IMU at 100 Hz over them.
class FakeDataset final : public dataset::SensorDatasetReader {
 public:
  explicit FakeDataset(int scans) : scans_(scans) {}
  dataset::SensorSetup sensor_setup() const override {
    dataset::SensorSetup setup;
    setup.sensor_model = "vlp16";
    setup.has_imu = true;
    return setup;
  }
  Trajectory ground_truth() override { return {}; }
  std::optional<double> progress() const override { return static_cast<double>(scan_) / scans_; }

 protected:
  bool read_imu(ImuSample& sample) override {
    if (imu_ > scans_ * 10) {
      return false;
    }
    sample.utime_us = kStartUs + 10'000 * imu_++;
    sample.accel_mps2 = Eigen::Vector3d(0, 0, 9.81);
    return true;
  }
  bool read_scan(LidarScan& scan) override {
    if (scan_ >= scans_) {
      return false;
    }
    scan.utime_us = kStartUs + 100'000 * scan_++;
    scan.points.assign(3, LidarPoint{Eigen::Vector3f(5, 0, 0), 1.0f, 0.0f, 0});
    return true;
  }

 private:
  static constexpr int64_t kStartUs = 1'000'000'000;
  int scans_, scan_ = 0, imu_ = 0;
};

transport::TransportConfig memq() {
  transport::TransportConfig c;
  c.url = "memq://";
  return c;
}

// What the node publishes on <robot>.IMU and <robot>.LIDAR of an in-process bus.
struct Received {
  int imu_samples = 0;
  std::vector<int64_t> scan_utimes;
};

Received run_ingest(dataset::SensorDatasetReader& reader, const IngestConfig& config,
                    IngestSummary* summary) {
  transport::Transport bus(memq());
  Received received;
  bus.subscribe<liloc::imu_t>(
      config.robot_id + ".IMU", [&](const liloc::imu_t& msg, const transport::ReceiveInfo&) {
        received.imu_samples += static_cast<int>(bridge::from_msg(msg).size());
      });
  bus.subscribe<liloc::lidar_scan_t>(
      config.robot_id + ".LIDAR",
      [&](const liloc::lidar_scan_t& msg, const transport::ReceiveInfo&) {
        received.scan_utimes.push_back(bridge::from_msg(msg).utime_us);
      });
  *summary = IngestNode(bus, reader, config).run();
  bus.drain();
  return received;
}

// Unpaced (speed 0): every sweep and sample of the dataset is published, in order, on the
// robot's channels.
TEST(IngestNode, PublishesEverySweepAndSampleOnTheRobotsChannels) {
  FakeDataset dataset(20);
  IngestConfig config;
  config.robot_id = "robot3";
  config.speed = 0.0;
  IngestSummary summary;
  const Received received = run_ingest(dataset, config, &summary);
  ASSERT_EQ(received.scan_utimes.size(), 20u);
  EXPECT_TRUE(std::is_sorted(received.scan_utimes.begin(), received.scan_utimes.end()));
  EXPECT_EQ(received.imu_samples, 201);
  EXPECT_FALSE(summary.stopped);
  EXPECT_NEAR(summary.data_s, 2.0, 1e-9);  // first sample to the last sweep's end
  EXPECT_EQ(dataset.stats().scans, 20);
}

// max_scans stops after that many sweeps; paced at 100x, 0.5 s of data take at least 5 ms.
TEST(IngestNode, StopsAtMaxScansAndPacesByTheDataClock) {
  FakeDataset dataset(20);
  IngestConfig config;
  config.speed = 100.0;
  config.max_scans = 5;
  IngestSummary summary;
  const Received received = run_ingest(dataset, config, &summary);
  EXPECT_EQ(received.scan_utimes.size(), 5u);
  EXPECT_NEAR(summary.data_s, 0.5, 1e-9);
  EXPECT_GE(summary.wall_s, 0.005);
}

TEST(IngestNode, RefusesABadConfig) {
  FakeDataset dataset(1);
  transport::Transport bus(memq());
  IngestConfig config;
  config.speed = -1.0;
  EXPECT_THROW(IngestNode(bus, dataset, config), std::invalid_argument);
  config.speed = 1.0;
  config.robot_id.clear();
  EXPECT_THROW(IngestNode(bus, dataset, config), std::invalid_argument);
}

}  // namespace
}  // namespace liloc
