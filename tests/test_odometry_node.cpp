#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <variant>

#include "app/process_memory.hpp"
#include "bridge/lcm_conversions.hpp"
#include "bridge/odometry_conversions.hpp"
#include "bridge/sensor_stream.hpp"
#include "eval/trajectory_metrics.hpp"
#include "liloc/status_t.hpp"
#include "odometry_node/odometry_node.hpp"
#include "sim/lidar_model.hpp"
#include "sim/session_recipe.hpp"
#include "sim/session_simulator.hpp"
#include "sim/vehicle_trajectory.hpp"

namespace liloc {
namespace {

// A short simulated drive (session A scaled to 30 m, VLP-16), recorded once: the sensor
// stream in the order a live robot sends it, and the ground truth.
struct Drive {
  std::vector<std::variant<ImuSample, LidarScan>> events;
  Trajectory ground_truth;
  sim::SimulationConfig config;
  int64_t sweeps = 0;
};

const Drive& drive() {
  static const Drive d = [] {
    Drive r;
    sim::scale_session_lengths(r.config.sessions, 0.02);
    const sim::SimulatedSessions sessions(r.config);
    const sim::SimulatedSession session = sessions.session("A");
    const sim::VehicleTrajectory trajectory(*session.world, session.plan.waypoints, r.config.motion,
                                            session.seed);
    const sim::SessionSimulator simulator(*session.world, trajectory, sim::lidar_spec("vlp16"),
                                          r.config.rig.rig(), r.config.imu, session.seed,
                                          session.start_utime);
    r.sweeps = simulator
                   .run([&](const ImuSample& s) { r.events.emplace_back(s); },
                        [&](const LidarScan& s) { r.events.emplace_back(s); }, [](double) {}, 2)
                   .sweeps;
    r.ground_truth = simulator.ground_truth(100.0);
    return r;
  }();
  return d;
}

OdometryNodeConfig node_config() {
  OdometryNodeConfig config;
  config.odometry.lidar_translation_m = drive().config.rig.lidar_translation_m;
  config.odometry.lidar_rpy_deg = drive().config.rig.lidar_rpy_deg;
  return config;
}

transport::TransportConfig memq() {
  transport::TransportConfig c;
  c.url = "memq://";
  return c;
}

struct Published {
  std::vector<liloc::odometry_t> odom;
  std::vector<Keyframe> keyframes;
  std::vector<liloc::status_t> status;

  Trajectory trajectory() const {
    std::vector<StampedPose> poses;
    for (const liloc::odometry_t& m : odom) {
      poses.push_back({m.header.utime * 1e-6, bridge::from_msg(m.pose)});
    }
    return Trajectory(poses);
  }
};

// Collects what the odometry node of `robot` publishes on `bus`.
void collect(transport::Transport& bus, const std::string& robot, Published& out) {
  const transport::ChannelConfig channels;
  bus.subscribe<liloc::odometry_t>(
      transport::robot_channel(robot, channels.odom),
      [&out](const liloc::odometry_t& m, const transport::ReceiveInfo&) { out.odom.push_back(m); });
  bus.subscribe<liloc::keyframe_t>(
      transport::robot_channel(robot, channels.keyframe),
      [&out](const liloc::keyframe_t& m, const transport::ReceiveInfo&) {
        out.keyframes.push_back(bridge::from_msg(m));
      });
  bus.subscribe<liloc::status_t>(
      transport::robot_channel(robot, channels.status) + ".odometry",
      [&out](const liloc::status_t& m, const transport::ReceiveInfo&) { out.status.push_back(m); });
}

// Sends the drive as robot0 would; `between(k)` runs after the k-th event (hostile input).
template <class Between>
void send_drive(transport::Transport& bus, Between between) {
  bridge::SensorStreamWriter sensors(bus, bridge::SensorStreamConfig{});
  int64_t k = 0;
  for (const auto& event : drive().events) {
    if (const auto* s = std::get_if<ImuSample>(&event)) {
      sensors.write_imu(*s);
    } else {
      sensors.write_scan(std::get<LidarScan>(event));
    }
    bus.drain();
    between(k++);
  }
}

double ate_m(const Published& out) {
  return eval::evaluate_trajectory(drive().ground_truth, out.trajectory(), eval::EvalConfig{})
      .ate_position_rmse_m;
}

// Two odometry nodes composed on one memq:// bus, fed a short simulated drive of robot0's
// as a live robot would send it: robot0's node tracks it, publishing odometry per sweep,
// keyframes and status; robot1's node, on the same bus, hears none of it.
TEST(OdometryNode, TracksADriveFromMessagesAndPublishesItsOutputs) {
  transport::Transport bus(memq());
  OdometryNode robot0(bus, "robot0", node_config());
  OdometryNode robot1(bus, "robot1", node_config());
  Published out0, out1;
  collect(bus, "robot0", out0);
  collect(bus, "robot1", out1);
  send_drive(bus, [](int64_t) {});
  robot0.finish();
  robot1.finish();
  bus.drain();

  // Every sweep but the few before the IMU had seen gravity long enough.
  EXPECT_EQ(static_cast<int64_t>(out0.odom.size()), robot0.counters().scans_processed);
  EXPECT_GE(static_cast<int64_t>(out0.odom.size()), drive().sweeps - 10);
  EXPECT_EQ(out0.status.size(), out0.odom.size());
  EXPECT_GE(out0.keyframes.size(), 20u);  // a keyframe a metre
  EXPECT_TRUE(out1.odom.empty());
  EXPECT_EQ(robot1.counters().scans_received, 0);
  EXPECT_LT(ate_m(out0), 0.1);
  EXPECT_EQ(out0.odom.back().header.robot_id, "robot0");
  EXPECT_EQ(out0.status.back().process, "odometry");
}

// The hostile input the issue lists, mixed into a good drive: every bad message is
// refused at the door with a counted reason, the odometry goes on with the good ones (its
// ATE as without them), status keeps coming while nothing else does, and memory stays
// bounded under the floods.
TEST(OdometryNode, RefusesHostileInputAndGoesOnWithTheGoodStream) {
  transport::Transport clean_bus(memq());
  OdometryNode clean_node(clean_bus, "robot0", node_config());
  Published clean;
  collect(clean_bus, "robot0", clean);
  send_drive(clean_bus, [](int64_t) {});
  clean_node.finish();
  clean_bus.drain();

  transport::Transport bus(memq());
  OdometryNode node(bus, "robot0", node_config());
  Published out;
  collect(bus, "robot0", out);
  const transport::ChannelConfig channels;
  const std::string imu_channel = transport::robot_channel("robot0", channels.imu);
  const std::string lidar_channel = transport::robot_channel("robot0", channels.lidar);
  const auto bad_scan = [&](double period_s, int64_t utime_us) {
    LidarScan scan;
    scan.utime_us = utime_us;
    scan.scan_period_s = period_s;
    scan.points.push_back({Eigen::Vector3f(5, 0, 0), 1.0f, 0.0f, 0});
    liloc::lidar_scan_t msg = bridge::to_msg(scan, "robot0", "lidar", "vlp16");
    bus.publish(lidar_channel, msg);
  };
  const auto bad_imu = [&](const Eigen::Vector3d& accel, int64_t utime_us) {
    liloc::imu_t msg =
        bridge::to_msg(std::vector<ImuSample>{{utime_us, accel, {0, 0, 0}}}, "robot0", "body");
    bus.publish(imu_channel, msg);
  };
  const int64_t start = drive().config.start_utime;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  send_drive(bus, [&](int64_t k) {
    if (k % 400 == 100) {
      bad_scan(nan, start + k * 2500);   // a NaN period
      bad_scan(-0.1, start + k * 2500);  // a negative period
    } else if (k % 400 == 200) {
      bad_scan(0.1, start + 3'000'000'000'000);  // a month in the future
      bad_imu(Eigen::Vector3d(0, 0, 9.8), start + 3'000'000'000'000);
    } else if (k % 400 == 300) {
      bad_imu(Eigen::Vector3d(1e6, 0, 9.8), start + k * 2500 + 1);  // beyond any IMU
    }
    bus.drain();
  });
  node.finish();
  bus.drain();

  const std::map<std::string, int64_t>& refused = node.rejected();
  EXPECT_GT(refused.at("scan_implausible"), 0);
  EXPECT_GT(refused.at("scan_time_jump"), 0);
  EXPECT_GT(refused.at("imu_time_jump"), 0);
  EXPECT_GT(refused.at("imu_implausible"), 0);
  EXPECT_EQ(node.counters().scans_failed, 0);
  EXPECT_EQ(out.odom.size(), clean.odom.size());
  EXPECT_NEAR(ate_m(out), ate_m(clean), 0.01) << "clean " << ate_m(clean);

  // Floods: sweeps 1 us apart with period 0, then IMU without LiDAR for 100 s. Each is
  // refused or bounded; status keeps coming with the reason.
  const ProcessMemory before = read_process_memory();
  const size_t statuses_before = out.status.size();
  const int64_t t0 = out.odom.back().header.utime + 1'000'000;
  for (int i = 0; i < 3000; ++i) {
    bad_scan(0.0, t0 + i);
    bus.drain();
  }
  for (int i = 0; i < 40000; ++i) {
    bad_imu(Eigen::Vector3d(0, 0, 9.81), t0 + 1'000'000 + i * 2500);
    if (i % 1000 == 0) {
      bus.drain();
      node.tick(node::wall_clock_us() + (i + 1) * 10'000'000LL);  // a status period each
    }
  }
  bus.drain();
  const ProcessMemory after = read_process_memory();
  EXPECT_GT(refused.at("scan_too_soon"), 2900);
  EXPECT_LT(after.rss_mb - before.rss_mb, 30.0);
  EXPECT_GE(out.status.size(), statuses_before + 40);  // a status per tick, no sweep
  const liloc::status_t& last = out.status.back();
  EXPECT_EQ(last.header.robot_id, "robot0");
  EXPECT_NE(last.message.find("last problem: sweep refused"), std::string::npos) << last.message;
  int64_t dropped_old = 0;
  for (int32_t i = 0; i < last.num_counters; ++i) {
    if (last.counter_names[i] == "imu_dropped_old") {
      dropped_old = last.counter_values[i];
    }
  }
  EXPECT_GT(dropped_old, 30000);  // 100 s of IMU, 10 s kept
}

// A stream whose clock really moved (a restarted sensor, a second log) is followed after a
// few messages that agree on it: the odometry restarts there instead of refusing every
// message as out of order.
TEST(OdometryNode, FollowsAClockThatReallyJumped) {
  transport::Transport bus(memq());
  OdometryNode node(bus, "robot0", node_config());
  Published out;
  collect(bus, "robot0", out);
  send_drive(bus, [](int64_t) {});
  const size_t first_run = out.odom.size();
  // The same drive again, as if the sensors' clocks had been reset an hour back.
  bridge::SensorStreamWriter sensors(bus, bridge::SensorStreamConfig{});
  for (const auto& event : drive().events) {
    if (const auto* s = std::get_if<ImuSample>(&event)) {
      ImuSample earlier = *s;
      earlier.utime_us -= 3'600'000'000;
      sensors.write_imu(earlier);
    } else {
      LidarScan earlier = std::get<LidarScan>(event);
      earlier.utime_us -= 3'600'000'000;
      sensors.write_scan(earlier);
    }
    bus.drain();
  }
  node.finish();
  bus.drain();
  EXPECT_GT(out.odom.size(), first_run + first_run / 2);
  EXPECT_GE(node.rejected().count("imu_time_jump"), 1u);
}

}  // namespace
}  // namespace liloc
