#pragma once
// Writes raw sensor data (IMU samples, LiDAR sweeps) as the messages live ingest
// publishes: to an LCM log (simulator, dataset conversion) or onto the bus (live
// ingest). Log events are stamped with the time the data becomes available: a sample's
// own time, a sweep's end.

#include <string>

#include "imu/imu_sample.hpp"
#include "pointcloud/point_cloud.hpp"
#include "transport/channels.hpp"
#include "transport/log_file.hpp"
#include "transport/transport.hpp"

namespace liloc::bridge {

struct SensorStreamConfig {
  std::string robot_id = "robot0";
  std::string imu_frame = "imu";
  std::string lidar_frame = "lidar";
  std::string sensor_model = "hdl32";
  transport::ChannelConfig channels;
};

class SensorStreamWriter {
 public:
  SensorStreamWriter(transport::LogWriter& log, SensorStreamConfig config);
  SensorStreamWriter(transport::Transport& bus, SensorStreamConfig config);

  void write_imu(const ImuSample& sample);
  void write_scan(const LidarScan& scan);

  int64_t imu_written() const { return imu_seq_; }
  int64_t scans_written() const { return scan_seq_; }

 private:
  template <class Msg>
  void emit(const std::string& channel, int64_t event_utime, Msg& msg);

  transport::LogWriter* log_ = nullptr;
  transport::Transport* bus_ = nullptr;
  SensorStreamConfig config_;
  std::string imu_channel_;
  std::string lidar_channel_;
  int64_t imu_seq_ = 0;
  int64_t scan_seq_ = 0;
};

}  // namespace liloc::bridge
