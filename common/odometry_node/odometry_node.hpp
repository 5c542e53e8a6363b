#pragma once
// The odometry process's logic (docs/odometry.md): LiDAR-inertial odometry of one robot
// over a Transport.
//   in:  <robot>.IMU, <robot>.LIDAR, <robot>.CORRECTION
//   out: <robot>.ODOM (every sweep), <robot>.KEYFRAME, <robot>.STATUS.odometry
// Every message is checked at the door (gate/sensor_gate.hpp) before the odometry sees
// it; what fails is counted and dropped with its reason. When no sweep comes out for a
// while, the status keeps coming with the reason (waiting for IMU, for LiDAR, a rejected
// sweep), so that monitoring never sees mere silence.

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bridge/odometry_conversions.hpp"
#include "gate/sensor_gate.hpp"
#include "node/node.hpp"
#include "odometry/lidar_inertial_odometry.hpp"
#include "transport/channels.hpp"
#include "transport/transport.hpp"

namespace liloc {

// The sections of the system config the odometry node reads.
struct OdometryNodeConfig {
  transport::ChannelConfig channels;
  SensorLimits sensors;
  OdometryConfig odometry;
  double status_period_s = 1.0;  // status at least this often, sweeps or not

  template <class V>
  void visit_fields(V& v) {
    v("channels", channels);
    v("sensors", sensors);
    v("odometry", odometry);
  }
};

class OdometryNode final : public node::Node {
 public:
  OdometryNode(transport::Transport& bus, const std::string& robot_id,
               const OdometryNodeConfig& config);

  std::string name() const override { return "odometry"; }
  // A status with the reason when no sweep came out for status_period_s.
  void tick(int64_t now_us) override;
  // Processes the sweeps still waiting for IMU data and logs the run's summary.
  bool finish() override;

  const OdometryCounters& counters() const { return odometry_->counters(); }
  // Messages refused at the door, by reason kind ("scan_period", "imu_time_jump", ...).
  const std::map<std::string, int64_t>& rejected() const { return rejected_; }

 private:
  // Converted at the door (bridge/): the samples or sweep, and how many non-finite values the
  // conversion dropped.
  void on_imu(const std::vector<ImuSample>& samples, size_t non_finite);
  void on_scan(LidarScan scan, size_t non_finite);
  // Counts and logs (rate-limited) a refused message; keeps the reason for the status.
  void reject(const std::string& kind, const std::string& reason);
  // A stream's clock confirmed a new time: the estimate restarts there.
  void restart(const std::string& why);
  void publish(const std::vector<OdometryEstimate>& estimates);
  void publish_status(const OdometryEstimate* e, int64_t utime_us);
  std::string waiting_reason() const;

  transport::Transport& bus_;
  std::string robot_id_;
  OdometryNodeConfig config_;
  std::unique_ptr<LidarInertialOdometry> odometry_;
  bridge::OdometryFrames frames_;
  std::string imu_channel_, lidar_channel_;
  std::string odom_channel_, keyframe_channel_, status_channel_;
  StreamClock imu_clock_, lidar_clock_;
  int64_t last_scan_start_us_ = 0;
  int64_t imu_received_ = 0, scans_received_ = 0;
  int64_t non_finite_imu_ = 0;
  int64_t non_finite_points_ = 0;
  int64_t restarts_ = 0;
  std::map<std::string, int64_t> rejected_;
  int64_t rejected_total_ = 0;
  std::string last_problem_;     // the latest refusal, restart or failure, for the status
  std::string extrinsic_check_;  // what the LiDAR-IMU extrinsic check found, once decided
  bool extrinsic_warned_ = false;
  int64_t last_status_wall_us_ = 0;
  int64_t last_data_utime_us_ = 0;
};

}  // namespace liloc
