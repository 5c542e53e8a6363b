#pragma once
// The odometry node over a recorded drive, in one process: the log replayed into an
// in-process bus (memq://, deterministic and lossless) where the node runs as the
// liloc_odometry process would; what it publishes comes back as core types. For
// liloc_map build and the benchmarks.

#include <functional>
#include <string>
#include <vector>

#include "math/trajectory.hpp"
#include "odometry_node/odometry_node.hpp"
#include "transport/log_file.hpp"

namespace liloc {

struct LogDrive {
  int64_t sweeps = 0;                   // odometry estimates published
  std::vector<StampedPose> trajectory;  // T_odom_body per sweep
  OdometryCounters counters;
  transport::LogDamage damage;
};

// Runs the node over the log; `on_keyframe` gets each keyframe as it is published, and
// `on_imu` (if given) the log's IMU samples as they are replayed. Throws what LogReader
// throws for an unreadable log.
LogDrive run_odometry_on_log(const std::string& log_path, const std::string& robot_id,
                             const OdometryNodeConfig& config,
                             const transport::TransportConfig& transport,
                             const std::function<void(const Keyframe&)>& on_keyframe,
                             const std::function<void(const ImuSample&)>& on_imu = {});

}  // namespace liloc
