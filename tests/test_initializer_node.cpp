#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <random>
#include <thread>

#include "bridge/init_conversions.hpp"
#include "bridge/lcm_conversions.hpp"
#include "initializer_node/initializer_node.hpp"
#include "liloc/init_result_t.hpp"
#include "liloc/status_t.hpp"
#include "map/keyframe_descriptors.hpp"
#include "map/submap_database.hpp"
#include "map_server_node/map_server_node.hpp"
#include "storage/map_store.hpp"

namespace liloc {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// A street 120 m long lined with boxes of random sizes: every place looks different.
std::vector<Eigen::Vector3f> street() {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 120000; ++i) {
    points.emplace_back(-30.0f + 180.0f * u(rng), -25.0f + 50.0f * u(rng), 0.0f);  // ground
  }
  for (int b = 0; b < 40; ++b) {
    const float cx = -20.0f + 160.0f * u(rng),
                cy = (b % 2 == 0 ? 1.0f : -1.0f) * (8.0f + 10.0f * u(rng));
    const float sx = 1.0f + 4.0f * u(rng), sy = 1.0f + 4.0f * u(rng), h = 2.0f + 8.0f * u(rng);
    for (int i = 0; i < 3000; ++i) {
      const float a = 2.0f * u(rng) - 1.0f, c = 2.0f * u(rng) - 1.0f, z = h * u(rng);
      points.emplace_back(cx + sx * (a > 0 ? 1.0f : -1.0f), cy + sy * c, z);
      points.emplace_back(cx + sx * a, cy + sy * (c > 0 ? 1.0f : -1.0f), z);
    }
  }
  return points;
}

// What a sensor 1.8 m above the street at `position` sees within 40 m, in its body frame.
PointCloud seen_from(const std::vector<Eigen::Vector3f>& world, const Eigen::Vector3d& position) {
  PointCloud cloud;
  for (const Eigen::Vector3f& p : world) {
    const Eigen::Vector3d d = p.cast<double>() - position;
    if (d.head<2>().norm() < 40.0) {
      cloud.push_back(d.cast<float>(), 1.0f);
    }
  }
  return cloud;
}

// The street as a map directory: a keyframe every metre along y = 0.
void write_street_map(const std::string& dir, const std::vector<Eigen::Vector3f>& world) {
  MapData map;
  map.map_id = "street";
  std::map<int64_t, PointCloud> clouds;
  for (int i = 0; i <= 100; ++i) {
    MapKeyframe kf;
    kf.id = i;
    kf.utime_us = 1'700'000'000'000'000 + i * 1'000'000LL;
    kf.session = "A";
    kf.T_map_body.translation() = Eigen::Vector3d(i, 0.0, 1.8);
    clouds[i] = seen_from(world, kf.T_map_body.translation());
    map.keyframes.push_back(kf);
  }
  map.submaps = join_submaps(map.keyframes, SubmapConfig{}, 0);
  storage::MapStore(dir).save(
      map, clouds, encode_keyframe_descriptors(map.keyframes, clouds, PolarDescriptorConfig{}));
}

struct Rig {
  std::string dir;
  std::vector<Eigen::Vector3f> world = street();
  std::unique_ptr<storage::MapStore> store;
  std::unique_ptr<transport::Transport> bus;
  std::unique_ptr<InitializerNode> initializer;
  std::unique_ptr<MapServerNode> server;
  std::vector<InitAnswer> answers;
  std::vector<liloc::status_t> status;

  explicit Rig(const std::string& name) {
    dir = ::testing::TempDir() + "liloc_initializer_node_" + name;
    fs::remove_all(dir);
    write_street_map(dir, world);
    store = std::make_unique<storage::MapStore>(dir);
    transport::TransportConfig memq;
    memq.url = "memq://";
    bus = std::make_unique<transport::Transport>(memq);
    InitializerNodeConfig config;
    config.initializer.request_period_s = 0.2;
    initializer = std::make_unique<InitializerNode>(*bus, "robot0", config);
    bus->subscribe<liloc::init_result_t>(
        "robot0.INIT", [this](const liloc::init_result_t& m, const transport::ReceiveInfo&) {
          answers.push_back(bridge::from_msg(m));
        });
    bus->subscribe<liloc::status_t>(
        "robot0.STATUS.initializer",
        [this](const liloc::status_t& m, const transport::ReceiveInfo&) { status.push_back(m); });
  }
  void start_server() {
    MapServerNodeConfig config;
    config.map_server.info_period_s = 0.1;
    server = std::make_unique<MapServerNode>(*bus, config, *store, store->load());
  }
  // Drains and ticks both nodes until `done` or timeout_s.
  bool run_until(const std::function<bool()>& done, double timeout_s = 20.0) {
    const Clock::time_point end = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                     std::chrono::duration<double>(timeout_s));
    int64_t now = node::wall_clock_us();
    while (!done() && Clock::now() < end) {
      bus->drain();
      now += 100'000;  // a tick period of node time per round
      initializer->tick(now);
      if (server) {
        server->tick(now);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    bus->drain();
    return done();
  }
  void send_keyframe(int64_t id, const Eigen::Isometry3d& T_odom_body, const PointCloud& cloud) {
    liloc::keyframe_t msg;
    msg.header = bridge::make_header(1'700'000'100'000'000 + id * 100'000, "robot0", "odom");
    msg.keyframe_id = id;
    msg.child_frame_id = "body";
    msg.pose = bridge::to_msg(T_odom_body);
    for (double& v : msg.linear_velocity) v = 0.0;
    for (double& v : msg.gyro_bias) v = 0.0;
    for (double& v : msg.accel_bias) v = 0.0;
    bridge::to_msg(Matrix6d::Identity(), msg.covariance);
    msg.fitness = 0.05f;
    msg.degenerate = false;
    msg.cloud = bridge::to_msg(cloud);
    bus->publish("robot0.KEYFRAME", msg);
  }
};

// The initializer and the map server composed over memq://, the server started after the
// initializer: the initializer says it waits, asks again, gets the map's keyframe index and
// the submaps it needs, and localizes a keyframe globally (no coarse pose) to within 5 cm.
TEST(InitializerNode, LocalizesGloballyWithAMapServerThatStartsLater) {
  Rig rig("global");
  const Eigen::Vector3d truth(40.4, 0.3, 1.8);
  // The odometry's frame: its own yaw and origin.
  const Eigen::Isometry3d T_odom_body =
      se3::make(Eigen::AngleAxisd(0.9, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
                Eigen::Vector3d(3, 4, 0));
  rig.send_keyframe(1, T_odom_body, seen_from(rig.world, truth));
  ASSERT_TRUE(rig.run_until([&] { return !rig.status.empty(); }));
  EXPECT_NE(rig.status.back().message.find("waiting for the map's keyframe index"),
            std::string::npos)
      << rig.status.back().message;
  EXPECT_TRUE(rig.answers.empty());
  rig.start_server();
  ASSERT_TRUE(rig.run_until([&] { return !rig.answers.empty(); }))
      << (rig.status.empty() ? "" : rig.status.back().message);
  const InitAnswer& a = rig.answers.back();
  ASSERT_TRUE(a.localized) << a.message;
  EXPECT_EQ(a.method, "global");
  EXPECT_EQ(a.keyframe_id, 1);
  // The body's yaw in the map is 0: the keyframe was taken looking along x.
  const Eigen::Isometry3d expected = se3::make(Eigen::Matrix3d::Identity(), truth);
  EXPECT_LT((a.T_map_body.translation() - truth).norm(), 0.05) << a.T_map_body.translation();
  EXPECT_LT(se3::rotation_angle(expected.inverse() * a.T_map_body), 0.01);
  EXPECT_GE(rig.initializer->counters().index_requests, 2);  // asked again for the late server
}

// A coarse pose asks for coarse-to-fine; asking again (the optimizer lost track) runs it
// again on the next keyframe.
TEST(InitializerNode, ReinitializesWhenAsked) {
  Rig rig("coarse");
  rig.start_server();
  CoarsePose coarse;
  coarse.x_m = 63.0;
  coarse.y_m = 2.0;
  coarse.yaw_rad = 0.3;
  liloc::pose_t ask = bridge::to_msg(coarse, 0, "robot0");
  rig.bus->publish("robot0.COARSE_POSE", ask);
  rig.send_keyframe(7, Eigen::Isometry3d::Identity(), seen_from(rig.world, {60.2, -0.4, 1.8}));
  ASSERT_TRUE(rig.run_until([&] { return !rig.answers.empty(); }));
  ASSERT_TRUE(rig.answers.back().localized) << rig.answers.back().message;
  EXPECT_EQ(rig.answers.back().method, "coarse_to_fine");
  EXPECT_LT((rig.answers.back().T_map_body.translation() - Eigen::Vector3d(60.2, -0.4, 1.8)).norm(),
            0.05);
  // Once localized it waits; asked again, it localizes the next keyframe.
  rig.send_keyframe(8, Eigen::Isometry3d::Identity(), seen_from(rig.world, {61.2, -0.4, 1.8}));
  rig.run_until([] { return false; }, 1.0);
  EXPECT_EQ(rig.answers.size(), 1u);
  coarse.x_m = 80.0;
  liloc::pose_t again = bridge::to_msg(coarse, 0, "robot0");
  rig.bus->publish("robot0.COARSE_POSE", again);
  rig.send_keyframe(9, Eigen::Isometry3d::Identity(), seen_from(rig.world, {78.0, 0.5, 1.8}));
  ASSERT_TRUE(rig.run_until([&] {
    return rig.answers.size() >= 2 && rig.answers.back().localized;
  })) << rig.answers.back().message;
  EXPECT_EQ(rig.answers.back().keyframe_id, 9);
}

}  // namespace
}  // namespace liloc
