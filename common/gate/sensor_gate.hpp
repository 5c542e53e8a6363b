#pragma once
// Plausibility at the door: what a sensor message must be before an algorithm sees it.
// A node checks every message of a type here, in one place; a message that fails is
// counted, logged with its reason (rate-limited) and dropped, so it never blocks the
// messages behind it. The limits are the sensors', not the algorithms'.

#include <cstdint>
#include <optional>
#include <string>

#include "imu/imu_sample.hpp"
#include "pointcloud/point_cloud.hpp"

namespace liloc {

struct SensorLimits {
  // A sweep lasting longer than this is no LiDAR sweep (spinning LiDARs: 0.05-0.2 s).
  double max_scan_period_s = 1.0;
  // Sweeps starting closer together than this come faster than any LiDAR turns.
  double min_scan_interval_s = 0.005;
  int max_scan_points = 2000000;  // a 128-beam sensor's dual-return sweep is ~1M
  // IMU samples beyond these are glitches, not motion (the range of common 16 g,
  // 2000 deg/s IMUs).
  double accel_limit_mps2 = 160.0;
  double gyro_limit_rps = 35.0;
  // A message more than max_time_jump_s from its stream's recent time is a jump and is
  // dropped, unless confirm_jump_messages messages in a row agree on the new time: then
  // that is the stream's time from now on (a restarted clock or log), and the node
  // restarts its estimate there.
  double max_time_jump_s = 5.0;
  int confirm_jump_messages = 10;

  template <class V>
  void visit_fields(V& v) {
    v("max_scan_period_s", max_scan_period_s);
    v("min_scan_interval_s", min_scan_interval_s);
    v("max_scan_points", max_scan_points);
    v("accel_limit_mps2", accel_limit_mps2);
    v("gyro_limit_rps", gyro_limit_rps);
    v("max_time_jump_s", max_time_jump_s);
    v("confirm_jump_messages", confirm_jump_messages);
  }
  void validate() const;
};

// Why a sweep or an IMU sample is implausible on its own, or nothing. Points are checked
// by the bridge (non-finite ones are dropped with a count).
std::optional<std::string> implausible_scan(const LidarScan& scan, const SensorLimits& limits);
std::optional<std::string> implausible_imu(const ImuSample& sample, const SensorLimits& limits);

// The time of one stream (a robot's IMU, its LiDAR), kept by its recent messages.
class StreamClock {
 public:
  enum class Verdict {
    kAccept,       // within max_time_jump_s of the stream's recent time
    kJump,         // far from it: drop the message
    kNewTimeline,  // the last confirm_jump_messages agree on a new time: accept, restart
  };

  StreamClock(double max_time_jump_s, int confirm_jump_messages);

  Verdict check(int64_t utime_us);

  int64_t jumps() const { return jumps_; }
  int64_t new_timelines() const { return new_timelines_; }

 private:
  int64_t max_jump_us_;
  int confirm_;
  std::optional<int64_t> latest_us_;
  std::optional<int64_t> candidate_latest_us_;  // of messages agreeing on another time
  int candidate_count_ = 0;
  int64_t jumps_ = 0;
  int64_t new_timelines_ = 0;
};

}  // namespace liloc
