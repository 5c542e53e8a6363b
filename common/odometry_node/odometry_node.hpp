#pragma once
// The odometry process's logic (docs/odometry.md): LiDAR-inertial odometry of one robot
// over a Transport.
//   in:  <robot>.IMU, <robot>.LIDAR, <robot>.CORRECTION
//   out: <robot>.ODOM (every sweep), <robot>.KEYFRAME, <robot>.STATUS.odometry

#include <string>
#include <vector>

#include "bridge/odometry_conversions.hpp"
#include "node/node.hpp"
#include "odometry/lidar_inertial_odometry.hpp"
#include "transport/channels.hpp"
#include "transport/transport.hpp"

namespace liloc {

// The sections of the system config the odometry node reads.
struct OdometryNodeConfig {
  transport::ChannelConfig channels;
  OdometryConfig odometry;

  template <class V>
  void visit_fields(V& v) {
    v("channels", channels);
    v("odometry", odometry);
  }
};

class OdometryNode final : public node::Node {
 public:
  OdometryNode(transport::Transport& bus, const std::string& robot_id,
               const OdometryNodeConfig& config);

  std::string name() const override { return "odometry"; }
  // Processes the sweeps still waiting for IMU data and logs the run's summary.
  bool finish() override;

  const OdometryCounters& counters() const { return odometry_.counters(); }

 private:
  void publish(const std::vector<OdometryEstimate>& estimates);
  void publish_status(const OdometryEstimate& e);

  transport::Transport& bus_;
  OdometryNodeConfig config_;
  LidarInertialOdometry odometry_;
  bridge::OdometryFrames frames_;
  std::string odom_channel_, keyframe_channel_, status_channel_;
  int64_t non_finite_imu_ = 0;
  int64_t non_finite_points_ = 0;
};

}  // namespace liloc
