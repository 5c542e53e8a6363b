#pragma once
// Pose initialization's messages <-> its core types.

#include "initializer/pose_initializer.hpp"
#include "liloc/init_result_t.hpp"
#include "liloc/keyframe_t.hpp"
#include "liloc/pose_t.hpp"

namespace liloc::bridge {

liloc::init_result_t to_msg(const InitAnswer& answer, const std::string& robot_id);
// Throws std::invalid_argument for a non-finite pose or covariance.
InitAnswer from_msg(const liloc::init_result_t& msg);

// A coarse pose (x, y, yaw and their sigmas) from a pose_t with its covariance (right
// perturbation: the sigmas of translation x, y and of rotation z). Throws
// std::invalid_argument for a non-finite pose or covariance.
CoarsePose coarse_pose_from_msg(const liloc::pose_t& msg);
liloc::pose_t to_msg(const CoarsePose& coarse, int64_t utime, const std::string& robot_id);

// A robot's keyframe as the query of an initialization. Throws std::invalid_argument for a
// non-finite pose.
InitQuery init_query_from_msg(const liloc::keyframe_t& msg);

}  // namespace liloc::bridge
