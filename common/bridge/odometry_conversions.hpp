#pragma once
// Messages of the odometry process <-> the odometry's core types.

#include <string>

#include "liloc/correction_t.hpp"
#include "liloc/keyframe_t.hpp"
#include "liloc/odometry_t.hpp"
#include "odometry/odometry_types.hpp"

namespace liloc::bridge {

struct OdometryFrames {
  std::string robot_id = "robot0";
  std::string odom_frame = "odom";
  std::string body_frame = "body";
};

liloc::odometry_t to_msg(const OdometryEstimate& estimate, const OdometryFrames& frames);
// Throws std::invalid_argument naming the field if a part is not finite.
OdometryEstimate from_msg(const liloc::odometry_t& msg);
liloc::keyframe_t to_msg(const Keyframe& keyframe, const OdometryFrames& frames);
// Throws std::invalid_argument (from the pose conversion) for a non-finite pose.
Keyframe from_msg(const liloc::keyframe_t& msg, size_t* non_finite_points = nullptr);
// Throws std::invalid_argument naming the field if a flagged part is not finite.
OdometryCorrection from_msg(const liloc::correction_t& msg);

}  // namespace liloc::bridge
