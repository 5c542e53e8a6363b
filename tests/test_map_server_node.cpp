#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <limits>
#include <thread>

#include "app/process_memory.hpp"
#include "bridge/map_conversions.hpp"
#include "liloc/status_t.hpp"
#include "map_server_node/map_server_node.hpp"
#include "map_test_data.hpp"

namespace liloc {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

std::string fresh_directory(const std::string& name) {
  const std::string dir = ::testing::TempDir() + "liloc_map_server_node_" + name;
  fs::remove_all(dir);
  return dir;
}

// A map server node on a memq:// bus with a robot's view of it: requests out, replies and
// status in.
struct ServedMap {
  explicit ServedMap(const std::string& name) : directory(fresh_directory(name)), store(directory) {
    test::write_map(directory);
    transport::TransportConfig memq;
    memq.url = "memq://";
    bus = std::make_unique<transport::Transport>(memq);
    MapServerNodeConfig config;
    config.map_server.service.reply_voxel_m = 0.0;  // full keyframe clouds, no derived files
    config.map_server.service.allowed_robots = {"robot0"};
    config.map_server.info_period_s = 0.01;
    server = std::make_unique<MapServerNode>(*bus, config, store, store.load());
    bus->subscribe<liloc::submap_t>(
        "robot0.SUBMAP", [this](const liloc::submap_t& m, const transport::ReceiveInfo&) {
          replies.push_back(bridge::from_msg(m));
        });
    bus->subscribe<liloc::status_t>(
        "MAP.STATUS", [this](const liloc::status_t& m, const transport::ReceiveInfo&) {
          for (int32_t i = 0; i < m.num_counters; ++i) {
            counters[m.counter_names[i]] = m.counter_values[i];
          }
        });
  }

  // Drains and ticks the node until `done` (replies come from worker threads, saves from
  // the saver's) or 10 s.
  bool run_until(const std::function<bool()>& done) {
    const Clock::time_point end = Clock::now() + std::chrono::seconds(10);
    while (!done() && Clock::now() < end) {
      bus->drain();
      server->tick(node::wall_clock_us());
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    bus->drain();
    return done();
  }

  void send(const MapUpdatePart& part) {
    liloc::map_update_t msg = bridge::to_msg(part, 0);
    bus->publish("MAP.UPDATE", msg);
    bus->drain();
  }

  std::string directory;
  storage::MapStore store;
  std::unique_ptr<transport::Transport> bus;
  std::unique_ptr<MapServerNode> server;
  std::vector<SubmapReplyPart> replies;
  std::map<std::string, int64_t> counters;
};

// A robot's update: n keyframes along y from (x0, 20), each with a small cloud.
MapUpdatePart update(const std::string& session, int64_t update_id, int n, double x0) {
  MapUpdatePart part;
  part.robot_id = "robot0";
  part.session_id = session;
  part.update_id = update_id;
  part.num_chunks = 1;
  for (int i = 0; i < n; ++i) {
    UpdateKeyframe kf;
    kf.sender_keyframe_id = i;
    kf.utime_us = 1000000LL * (100 + i);
    kf.T_map_body.translation() = Eigen::Vector3d(x0, 20.0 + i, 0.0);
    kf.fitness_m = 0.05;
    for (int k = 0; k < 50; ++k) {
      kf.cloud_body.push_back(Eigen::Vector3f(0.1f * k, 0, -1), 1.0f);
    }
    part.keyframes.push_back(kf);
  }
  return part;
}

// The node over memq://: a request answered on the robot's channel with its clouds, a bad
// update refused with the save's own rule, a good update after it merged, saved as the
// next version and served; its status says so; it finishes with nothing lost.
TEST(MapServerNode, AnswersMergesSavesAndReports) {
  ServedMap served("serve");
  SubmapQuery query;
  query.robot_id = "robot0";
  query.request_id = 1;
  query.position = Eigen::Vector3d(30, 0, 0);
  liloc::submap_request_t request = bridge::to_msg(query, 0);
  served.bus->publish("MAP.REQUEST", request);
  ASSERT_TRUE(served.run_until([&] { return !served.replies.empty(); }));
  ASSERT_TRUE(served.replies[0].submap);
  EXPECT_EQ(served.replies[0].submap->id, 1);
  ASSERT_TRUE(served.replies[0].clouds);
  EXPECT_EQ(served.replies[0].clouds->keyframes(), 20u);

  served.send(update("B,C", 1, 5, 3.0));  // a ',' in the session: the files cannot hold it
  served.send(update("B", 2, 25, 3.0));
  ASSERT_TRUE(served.run_until([&] { return served.counters["map_version"] == 2; }));
  EXPECT_EQ(served.counters["updates_rejected"], 1);
  EXPECT_EQ(served.counters["updates_merged"], 1);
  EXPECT_EQ(served.counters["unsaved_keyframes"], 0);
  EXPECT_TRUE(served.server->finish());
  const MapData on_disk = storage::MapStore(served.directory).load();
  EXPECT_EQ(on_disk.version, 2);
  EXPECT_EQ(on_disk.keyframes.size(), 70u);
  EXPECT_EQ(on_disk.keyframes.back().session, "B");
  EXPECT_EQ(served.server->map().keyframes.size(), 70u);
}

// Hostile and malformed updates in floods: each is refused with a counted reason, the
// pending state stays within its bounds, memory stays bounded, and a good update after
// them all is merged and saved.
TEST(MapServerNode, StaysBoundedAndKeepsSavingUnderFloods) {
  ServedMap served("flood");
  const ProcessMemory before = read_process_memory();
  for (int64_t id = 0; id < 2000; ++id) {  // chunk 0 of 2, never completed
    MapUpdatePart part = update("B", 100 + id, 20, 3.0);
    part.num_chunks = 2;
    served.send(part);
  }
  for (int64_t id = 0; id < 1000; ++id) {  // senders the config does not name
    MapUpdatePart part = update("B", id, 2, 3.0);
    part.robot_id = "stranger" + std::to_string(id);
    served.send(part);
  }
  for (const double bad : {std::nan(""), std::numeric_limits<double>::infinity()}) {
    MapUpdatePart part = update("B", 5000, 2, 3.0);
    part.keyframes[1].fitness_m = bad;
    served.send(part);
  }
  MapUpdatePart far = update("B", 5001, 2, 3.0);
  far.keyframes[0].T_map_body.translation().x() = 1e308;
  served.send(far);
  for (const std::string& session : {std::string("a,b"), std::string("q\"x"), std::string("\t")}) {
    served.send(update(session, 5002, 2, 3.0));
  }
  SubmapQuery query;
  query.robot_id = "bad\nrobot";
  liloc::submap_request_t request = bridge::to_msg(query, 0);
  served.bus->publish("MAP.REQUEST", request);
  served.send(update("B", 9000, 25, 3.0));
  ASSERT_TRUE(served.run_until([&] { return served.counters["map_version"] == 2; }));
  const ProcessMemory after = read_process_memory();
  EXPECT_EQ(served.counters["updates_merged"], 1);
  EXPECT_EQ(served.counters["updates_pending"], 8);  // max_pending_updates
  EXPECT_EQ(served.counters["updates_refused_busy"], 1992);
  EXPECT_EQ(served.counters["updates_refused_robot"], 1000);
  EXPECT_EQ(served.counters["updates_rejected"], 6);
  EXPECT_EQ(served.counters["requests_refused"], 1);
  EXPECT_LT(after.rss_mb - before.rss_mb, 60.0);
  EXPECT_TRUE(served.server->finish());
}

// The saver never lets one bad change block the others: a delta the map's rules refuse is
// dropped and reported, the next one saved (the map service refuses such updates before
// they merge; this is the saver's own guard).
TEST(MapSaver, ADeltaThatCannotBeSavedDoesNotBlockTheNext) {
  const std::string dir = fresh_directory("saver");
  test::write_map(dir);
  storage::MapStore store(dir);
  MapSaver saver(store, store.load(), 5);
  const auto delta = [](int64_t first_id, const std::string& session) {
    MapDelta d;
    for (int64_t id = first_id; id < first_id + 3; ++id) {
      MapKeyframe kf;
      kf.id = id;
      kf.session = session;
      kf.T_map_body.translation() = Eigen::Vector3d(0, static_cast<double>(id), 0);
      d.keyframes.push_back(kf);
      auto cloud = std::make_shared<PointCloud>();
      cloud->push_back(Eigen::Vector3f::Zero(), 0.0f);
      d.clouds[id] = cloud;
      d.descriptors[id] = encode(make_polar_descriptor(*cloud, PolarDescriptorConfig{}));
    }
    return d;
  };
  saver.submit(delta(45, "bad\nname"));
  saver.submit(delta(48, "B"));
  EXPECT_EQ(saver.finish(), 0);
  int64_t dropped = 0, version = 0;
  for (const MapSaver::Result& r : saver.take_results()) {
    dropped += r.dropped_keyframes;
    version = std::max(version, r.version);
  }
  EXPECT_EQ(dropped, 3);
  EXPECT_EQ(version, 2);
  const MapData on_disk = store.load();
  EXPECT_EQ(on_disk.keyframes.size(), 48u);
  EXPECT_EQ(on_disk.keyframes.back().id, 50);
}

}  // namespace
}  // namespace liloc
