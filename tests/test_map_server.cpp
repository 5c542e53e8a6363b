// The liloc_map_server process itself, over loopback multicast (ttl=0): it loads a map
// directory, answers a position query and a request with clouds on the robot's own
// reply group, refuses a reply URL it cannot serve and a malformed update (both counted
// in MAP.STATUS), writes the submaps' reply clouds next to the map, and stops cleanly on
// SIGINT. Every wait is bounded.

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "app/child_process.hpp"
#include "bridge/map_conversions.hpp"
#include "liloc/status_t.hpp"
#include "map_test_data.hpp"
#include "node/reply_route.hpp"
#include "storage/map_store.hpp"
#include "transport/channels.hpp"
#include "transport/transport.hpp"

namespace liloc {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr const char* kRobot = "robot7";  // allowed to update by config/liloc.yaml

// Ports of this test only (7800-7999, by process id), so that it runs beside other tests,
// the demo and the same test of another build tree.
std::string url() {
  return "udpm://239.255.76.67:" + std::to_string(7800 + 10 * (::getpid() % 20)) +
         "?ttl=0&recv_buf_size=2097152";
}

class Robot {
 public:
  // Replies come on the robot's own port (node/reply_route.hpp), as the server computes it.
  Robot()
      : bus_(config(url())),
        replies_(config(node::reply_url(url(), transport::TransportConfig{}.reply_ports, kRobot))) {
    replies_.subscribe<liloc::submap_t>(
        transport::robot_channel(kRobot, "SUBMAP"),
        [this](const liloc::submap_t& msg, const transport::ReceiveInfo&) {
          parts_[msg.request_id].push_back(bridge::from_msg(msg));
        });
    bus_.subscribe<liloc::status_t>(
        "MAP.STATUS", [this](const liloc::status_t& msg, const transport::ReceiveInfo&) {
          for (int32_t i = 0; i < msg.num_counters; ++i) {
            counters_[msg.counter_names[i]] = msg.counter_values[i];
          }
        });
  }

  int64_t request(SubmapQuery q) {
    q.robot_id = kRobot;
    q.request_id = ++last_request_;
    liloc::submap_request_t msg = bridge::to_msg(q, 0);
    bus_.publish(transport::ChannelConfig{}.map_request, msg);
    return q.request_id;
  }

  // Handles messages until `done` or timeout_s: whether `done` came true.
  bool wait(const std::function<bool()>& done, double timeout_s) {
    const Clock::time_point end = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                     std::chrono::duration<double>(timeout_s));
    while (!done() && Clock::now() < end) {
      bus_.handle(10);
      replies_.handle(10);
    }
    return done();
  }

  // The whole reply to `request_id`, once all its parts came.
  bool complete(int64_t request_id) const {
    const auto it = parts_.find(request_id);
    return it != parts_.end() && !it->second.empty() &&
           static_cast<int>(it->second.size()) == it->second.front().reply_count;
  }
  const std::vector<SubmapReplyPart>& parts(int64_t request_id) { return parts_[request_id]; }
  int64_t counter(const std::string& name) const {
    const auto it = counters_.find(name);
    return it == counters_.end() ? 0 : it->second;
  }
  transport::Transport& bus() { return bus_; }

 private:
  static transport::TransportConfig config(const std::string& url) {
    transport::TransportConfig c;
    c.url = url;
    return c;
  }
  transport::Transport bus_;
  transport::Transport replies_;
  std::map<int64_t, std::vector<SubmapReplyPart>> parts_;
  std::map<std::string, int64_t> counters_;
  int64_t last_request_ = 0;
};

TEST(MapServerProcess, ServesRobotsRefusesBadInputAndStopsCleanly) {
  const std::string dir =
      ::testing::TempDir() + "liloc_map_server_process_" + std::to_string(::getpid());
  fs::remove_all(dir);
  const std::map<int64_t, PointCloud> clouds = test::write_map(dir + "/map");
  // Killed if an assertion ends the test early, so that no orphan keeps the ports.
  ChildProcess server(LILOC_MAP_SERVER, {"--config", LILOC_SOURCE_DIR "/config/liloc.yaml", "--map",
                                         dir + "/map", "--lcm-url", url(), "--log-level", "warn"});
  Robot robot;

  // Where am I: the nearest submap, no clouds. The server is up once it answers.
  SubmapQuery where;
  where.position = Eigen::Vector3d(27.0, 0.5, 0.0);
  where.include_clouds = false;
  where.reply_url = "udpm://239.255.76.67:9?ttl=1";  // ignored: the server picks the route
  int64_t asked = 0;
  for (int attempt = 0; attempt < 30 && (asked == 0 || !robot.complete(asked)); ++attempt) {
    asked = robot.request(where);
    robot.wait([&] { return robot.complete(asked); }, 1.0);
  }
  ASSERT_TRUE(robot.complete(asked)) << "no answer from liloc_map_server in 30 s";
  ASSERT_EQ(robot.parts(asked).size(), 1u);
  ASSERT_TRUE(robot.parts(asked)[0].submap);
  EXPECT_EQ(robot.parts(asked)[0].submap->id, 1);  // keyframes 20-39
  EXPECT_FALSE(robot.parts(asked)[0].clouds);

  // Submap 0 with its clouds: 20 keyframes, every point within half a centimetre of one
  // of its keyframe's points, each 0.3 m map voxel once.
  SubmapQuery fetch;
  fetch.by_id = true;
  fetch.submap_ids = {0};
  const int64_t fetched = robot.request(fetch);
  ASSERT_TRUE(robot.wait([&] { return robot.complete(fetched); }, 10.0));
  size_t keyframes = 0, points = 0;
  for (const SubmapReplyPart& part : robot.parts(fetched)) {
    ASSERT_TRUE(part.clouds);
    for (size_t k = 0; k < part.keyframes.size(); ++k, ++keyframes) {
      const PointCloud& original = clouds.at(part.keyframes[k].id);
      for (const Eigen::Vector3f& p : part.clouds->keyframe_cloud(k).points) {
        float nearest = 1e9f;
        for (const Eigen::Vector3f& q : original.points) {
          nearest = std::min(nearest, (p - q).cwiseAbs().maxCoeff());
        }
        EXPECT_LE(nearest, 0.005f + 1e-4f);
        ++points;
      }
    }
  }
  EXPECT_EQ(keyframes, 20u);
  EXPECT_GT(points, 0u);
  EXPECT_LT(points, 20u * 1500u / 2u);  // deduplicated: far fewer than 20 full clouds

  // An update from a robot the config does not name: refused, counted. One with a
  // non-finite pose: rejected, counted.
  MapUpdatePart intruder;
  intruder.robot_id = "intruder";
  intruder.session_id = "X";
  intruder.update_id = 1;
  intruder.num_chunks = 1;
  liloc::map_update_t intruder_msg = bridge::to_msg(intruder, 0);
  robot.bus().publish(transport::ChannelConfig{}.map_update, intruder_msg);
  MapUpdatePart update;
  update.robot_id = kRobot;
  update.session_id = "B";
  update.update_id = 1;
  update.num_chunks = 1;
  UpdateKeyframe kf;
  kf.T_map_body.translation().x() = std::nan("");
  kf.cloud_body.push_back(Eigen::Vector3f::Zero(), 0.0f);
  update.keyframes.push_back(kf);
  liloc::map_update_t update_msg = bridge::to_msg(update, 0);
  robot.bus().publish(transport::ChannelConfig{}.map_update, update_msg);
  EXPECT_TRUE(robot.wait(
      [&] {
        return robot.counter("updates_refused_robot") >= 1 &&
               robot.counter("updates_rejected") >= 1;
      },
      5.0))
      << "updates_refused_robot " << robot.counter("updates_refused_robot") << ", updates_rejected "
      << robot.counter("updates_rejected");

  // The background filler computes the reply clouds the map lacks at start (all three, or
  // two if the request above computed submap 0 first) and reports when done; then all
  // are on disk. SIGINT: a clean exit.
  EXPECT_TRUE(robot.wait([&] { return robot.counter("submap_clouds_computed") >= 2; }, 10.0))
      << "submap_clouds_computed " << robot.counter("submap_clouds_computed");
  EXPECT_EQ(server.stop(SIGINT, 15.0), 0);
  size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir + "/map/derived/submap_clouds")) {
    files += entry.path().extension() == ".bin" ? 1 : 0;
  }
  EXPECT_EQ(files, 3u);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace liloc
