#include "bridge/sensor_stream.hpp"

#include <cmath>

#include "bridge/lcm_conversions.hpp"

namespace liloc::bridge {

SensorStreamWriter::SensorStreamWriter(transport::LogWriter& log, SensorStreamConfig config)
    : log_(&log),
      config_(std::move(config)),
      imu_channel_(transport::robot_channel(config_.robot_id, config_.channels.imu)),
      lidar_channel_(transport::robot_channel(config_.robot_id, config_.channels.lidar)) {}

SensorStreamWriter::SensorStreamWriter(transport::Transport& bus, SensorStreamConfig config)
    : bus_(&bus),
      config_(std::move(config)),
      imu_channel_(transport::robot_channel(config_.robot_id, config_.channels.imu)),
      lidar_channel_(transport::robot_channel(config_.robot_id, config_.channels.lidar)) {}

template <class Msg>
void SensorStreamWriter::emit(const std::string& channel, int64_t event_utime, Msg& msg) {
  if (bus_ != nullptr) {
    bus_->publish(channel, msg);  // numbers the message itself
  } else {
    log_->write(channel, event_utime, msg);
  }
}

void SensorStreamWriter::write_imu(const ImuSample& sample) {
  liloc::imu_t msg = to_msg(std::vector<ImuSample>{sample}, config_.robot_id, config_.imu_frame);
  msg.header.seq = imu_seq_++;
  emit(imu_channel_, sample.utime_us, msg);
}

void SensorStreamWriter::write_scan(const LidarScan& scan) {
  liloc::lidar_scan_t msg =
      to_msg(scan, config_.robot_id, config_.lidar_frame, config_.sensor_model);
  msg.header.seq = scan_seq_++;
  const int64_t end_utime =
      scan.utime_us + static_cast<int64_t>(std::llround(scan.scan_period_s * 1e6));
  emit(lidar_channel_, end_utime, msg);
}

}  // namespace liloc::bridge
