#include <gtest/gtest.h>

#include "bridge/lcm_conversions.hpp"
#include "bridge/odometry_conversions.hpp"
#include "bridge/sensor_stream.hpp"
#include "liloc/status_t.hpp"
#include "odometry_node/odometry_node.hpp"
#include "sim/lidar_model.hpp"
#include "sim/session_recipe.hpp"
#include "sim/session_simulator.hpp"
#include "sim/vehicle_trajectory.hpp"

namespace liloc {
namespace {

struct Published {
  std::vector<liloc::odometry_t> odom;
  std::vector<Keyframe> keyframes;
  std::vector<liloc::status_t> status;
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

// Two odometry nodes composed on one memq:// bus, fed a short simulated drive of robot0's
// as a live robot would send it: robot0's node tracks it, publishing odometry per sweep,
// keyframes and status; robot1's node, on the same bus, hears none of it.
TEST(OdometryNode, TracksADriveFromMessagesAndPublishesItsOutputs) {
  sim::SimulationConfig sim_config;
  sim::scale_session_lengths(sim_config.sessions, 0.02);  // session A: 30 m
  const sim::SimulatedSessions sessions(sim_config);
  const sim::SimulatedSession session = sessions.session("A");
  const sim::VehicleTrajectory trajectory(*session.world, session.plan.waypoints, sim_config.motion,
                                          session.seed);
  const sim::SessionSimulator simulator(*session.world, trajectory, sim::lidar_spec("vlp16"),
                                        sim_config.rig.rig(), sim_config.imu, session.seed,
                                        session.start_utime);

  transport::TransportConfig memq;
  memq.url = "memq://";
  transport::Transport bus(memq);
  OdometryNodeConfig config;
  config.odometry.lidar_translation_m = sim_config.rig.lidar_translation_m;
  config.odometry.lidar_rpy_deg = sim_config.rig.lidar_rpy_deg;
  OdometryNode robot0(bus, "robot0", config);
  OdometryNode robot1(bus, "robot1", config);
  Published out0, out1;
  collect(bus, "robot0", out0);
  collect(bus, "robot1", out1);

  bridge::SensorStreamWriter sensors(bus, bridge::SensorStreamConfig{});  // robot0
  const sim::SessionStats stats = simulator.run(
      [&](const ImuSample& s) {
        sensors.write_imu(s);
        bus.drain();
      },
      [&](const LidarScan& s) {
        sensors.write_scan(s);
        bus.drain();
      },
      [](double) {}, 2);
  robot0.finish();
  robot1.finish();
  bus.drain();

  // Every sweep but the few before the IMU had seen gravity long enough.
  EXPECT_EQ(static_cast<int64_t>(out0.odom.size()), robot0.counters().scans_processed);
  EXPECT_GE(static_cast<int64_t>(out0.odom.size()), stats.sweeps - 10);
  EXPECT_EQ(out0.status.size(), out0.odom.size());
  EXPECT_GE(out0.keyframes.size(), 20u);  // a keyframe a metre
  EXPECT_TRUE(out1.odom.empty());
  EXPECT_EQ(robot1.counters().scans_received, 0);
  // The last pose, in the odom frame (the first body pose), against the truth.
  const liloc::odometry_t& last = out0.odom.back();
  const Eigen::Isometry3d truth0 = trajectory.pose(0.0);
  const Eigen::Isometry3d truth = trajectory.pose((last.header.utime - session.start_utime) * 1e-6);
  const Eigen::Isometry3d estimate = bridge::from_msg(last.pose);
  const double error_m = ((truth0.inverse() * truth).translation() - estimate.translation()).norm();
  EXPECT_LT(error_m, 0.3) << "after " << trajectory.length_m() << " m";
  EXPECT_EQ(last.header.robot_id, "robot0");
  EXPECT_EQ(out0.status.back().process, "odometry");
}

}  // namespace
}  // namespace liloc
