#pragma once
// Channel names. Per-robot channels are "<robot_id>.<suffix>" so that several robots
// share one bus; map channels are global. Every name is configurable.

#include <algorithm>
#include <cctype>
#include <stdexcept>
#include <string>

namespace liloc::transport {

struct ChannelConfig {
  // Per robot (prefixed with "<robot_id>.").
  std::string imu = "IMU";                  // imu_t
  std::string lidar = "LIDAR";              // lidar_scan_t
  std::string odom = "ODOM";                // odometry_t, odom frame
  std::string keyframe = "KEYFRAME";        // keyframe_t
  std::string correction = "CORRECTION";    // correction_t
  std::string coarse_pose = "COARSE_POSE";  // pose_t
  std::string init = "INIT";                // init_result_t
  std::string pose = "POSE";                // odometry_t, map frame
  std::string status = "STATUS";            // status_t, as "<robot>.STATUS.<process>"
  std::string submap = "SUBMAP";            // submap_t, replies addressed to the robot
  // Global.
  std::string map_request = "MAP.REQUEST";                    // submap_request_t
  std::string map_update = "MAP.UPDATE";                      // map_update_t
  std::string map_info = "MAP.INFO";                          // map_info_t
  std::string descriptor_request = "MAP.DESCRIPTOR_REQUEST";  // descriptor_request_t
  std::string descriptors = "DESCRIPTORS";  // keyframe_descriptors_t, per robot, replies

  template <class V>
  void visit_fields(V& v) {
    v("imu", imu);
    v("lidar", lidar);
    v("odom", odom);
    v("keyframe", keyframe);
    v("correction", correction);
    v("coarse_pose", coarse_pose);
    v("init", init);
    v("pose", pose);
    v("status", status);
    v("submap", submap);
    v("map_request", map_request);
    v("map_update", map_update);
    v("map_info", map_info);
    v("descriptor_request", descriptor_request);
    v("descriptors", descriptors);
  }
  // Names are LCM channels (a robot id and a dot before per-robot ones): not empty, at most
  // 40 characters of letters, digits, '.', '_' or '-'.
  void validate() const;
};

inline void ChannelConfig::validate() const {
  ChannelConfig copy = *this;
  auto check = [](const char* key, const std::string& name) {
    const bool plain = std::all_of(name.begin(), name.end(), [](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-';
    });
    if (name.empty() || name.size() > 40 || !plain) {
      throw std::invalid_argument(std::string(key) + " '" + name +
                                  "' must be 1-40 letters, digits, '.', '_' or '-'");
    }
  };
  copy.visit_fields(check);
}

inline std::string robot_channel(const std::string& robot_id, const std::string& suffix) {
  return robot_id + "." + suffix;
}

}  // namespace liloc::transport
