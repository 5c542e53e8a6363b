#include "odometry_node/log_drive.hpp"

#include "bridge/lcm_conversions.hpp"
#include "bridge/odometry_conversions.hpp"

namespace liloc {

LogDrive run_odometry_on_log(const std::string& log_path, const std::string& robot_id,
                             const OdometryNodeConfig& config,
                             const transport::TransportConfig& transport,
                             const std::function<void(const Keyframe&)>& on_keyframe,
                             const std::function<void(const ImuSample&)>& on_imu) {
  transport::TransportConfig in_process = transport;
  in_process.url = "memq://";
  in_process.publish_url.clear();
  transport::Transport bus(in_process);
  OdometryNode odometry(bus, robot_id, config);
  LogDrive drive;
  bus.subscribe<liloc::odometry_t>(
      transport::robot_channel(robot_id, config.channels.odom),
      [&](const liloc::odometry_t& msg, const transport::ReceiveInfo&) {
        ++drive.sweeps;
        drive.trajectory.push_back({msg.header.utime * 1e-6, bridge::from_msg(msg.pose)});
      });
  bus.subscribe<liloc::keyframe_t>(
      transport::robot_channel(robot_id, config.channels.keyframe),
      [&](const liloc::keyframe_t& msg, const transport::ReceiveInfo&) {
        on_keyframe(bridge::from_msg(msg));
      });
  if (on_imu) {
    bus.subscribe<liloc::imu_t>(transport::robot_channel(robot_id, config.channels.imu),
                                [&](const liloc::imu_t& msg, const transport::ReceiveInfo&) {
                                  for (const ImuSample& s : bridge::from_msg(msg)) {
                                    on_imu(s);
                                  }
                                });
  }
  drive.damage = transport::replay_log(log_path, bus, {}).damage;
  odometry.finish();
  bus.drain();
  drive.counters = odometry.counters();
  return drive;
}

}  // namespace liloc
