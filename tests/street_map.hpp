#pragma once
// A simulated street and its map directory, for the tests of the nodes that localize
// against a map server (initializer, optimizer).

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "bridge/lcm_conversions.hpp"
#include "descriptor/polar_descriptor.hpp"
#include "liloc/keyframe_t.hpp"
#include "map/keyframe_descriptors.hpp"
#include "map/submap_database.hpp"
#include "map_server_node/map_server_node.hpp"
#include "node/node.hpp"
#include "pointcloud/point_cloud.hpp"
#include "storage/map_store.hpp"
#include "transport/transport.hpp"

namespace liloc::test {

// A street 120 m long lined with boxes of random sizes: every place looks different.
inline std::vector<Eigen::Vector3f> street() {
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
inline PointCloud seen_from(const std::vector<Eigen::Vector3f>& world,
                            const Eigen::Vector3d& position) {
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
inline void write_street_map(const std::string& dir, const std::vector<Eigen::Vector3f>& world) {
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

// The street's map directory, a memq:// bus, the map server (when started) and the nodes
// under test, run together.
struct StreetRig {
  std::string dir;
  std::vector<Eigen::Vector3f> world = street();
  std::unique_ptr<storage::MapStore> store;
  std::unique_ptr<transport::Transport> bus;
  std::unique_ptr<MapServerNode> server;
  std::vector<node::Node*> nodes;  // ticked with the server
  int64_t now_us = 0;              // the nodes' clock

  explicit StreetRig(const std::string& name) {
    dir = ::testing::TempDir() + name;
    std::filesystem::remove_all(dir);
    write_street_map(dir, world);
    store = std::make_unique<storage::MapStore>(dir);
    transport::TransportConfig memq;
    memq.url = "memq://";
    bus = std::make_unique<transport::Transport>(memq);
  }
  void start_server(const std::vector<std::string>& allowed_robots = {}) {
    MapServerNodeConfig config;
    config.map_server.info_period_s = 0.1;
    config.map_server.service.allowed_robots = allowed_robots;
    server = std::make_unique<MapServerNode>(*bus, config, *store, store->load());
  }
  // Drains and ticks the nodes until `done` or timeout_s.
  bool run_until(const std::function<bool()>& done, double timeout_s = 20.0) {
    using Clock = std::chrono::steady_clock;
    const Clock::time_point end = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                     std::chrono::duration<double>(timeout_s));
    while (!done() && Clock::now() < end) {
      bus->drain();
      // A tick period of node time per round, never going back between calls.
      now_us = std::max(now_us + 100'000, node::wall_clock_us());
      for (node::Node* n : nodes) {
        n->tick(now_us);
      }
      if (server) {
        server->tick(now_us);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    bus->drain();
    return done();
  }
  // A keyframe of a robot's odometry, 0.1 s apart by id, with its covariance (1 mm, 1 mrad).
  void send_keyframe(int64_t id, const Eigen::Isometry3d& T_odom_body, const PointCloud& cloud,
                     const std::string& robot = "robot0",
                     const Matrix6d& covariance = Matrix6d::Identity() * 1e-6) {
    liloc::keyframe_t msg;
    msg.header = bridge::make_header(1'700'000'100'000'000 + id * 100'000, robot, "odom");
    msg.keyframe_id = id;
    msg.child_frame_id = "body";
    msg.pose = bridge::to_msg(T_odom_body);
    for (double& v : msg.linear_velocity) v = 0.0;
    for (double& v : msg.gyro_bias) v = 0.0;
    for (double& v : msg.accel_bias) v = 0.0;
    bridge::to_msg(covariance, msg.covariance);
    msg.fitness = 0.05f;
    msg.degenerate = false;
    msg.cloud = bridge::to_msg(cloud);
    bus->publish(robot + ".KEYFRAME", msg);
  }
};

}  // namespace liloc::test
