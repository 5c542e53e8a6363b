#include "bridge/init_conversions.hpp"

#include <cmath>
#include <stdexcept>

#include "bridge/lcm_conversions.hpp"
#include "math/so3.hpp"

namespace liloc::bridge {

liloc::init_result_t to_msg(const InitAnswer& a, const std::string& robot_id) {
  liloc::init_result_t msg;
  msg.header = make_header(a.utime_us, robot_id, "map");
  msg.status =
      a.localized ? liloc::init_result_t::STATUS_SUCCESS : liloc::init_result_t::STATUS_FAILED;
  msg.method = a.method;
  msg.message = a.message;
  msg.keyframe_id = a.keyframe_id;
  msg.pose = to_msg(a.T_map_body);
  to_msg(a.covariance, msg.covariance);
  msg.fitness = static_cast<float>(a.fitness_m);
  msg.descriptor_distance = static_cast<float>(a.descriptor_distance);
  msg.matched_submap_id = a.matched_submap_id;
  msg.matched_keyframe_id = a.matched_keyframe_id;
  msg.time_ms = static_cast<float>(a.time_ms);
  return msg;
}

InitAnswer from_msg(const liloc::init_result_t& msg) {
  InitAnswer a;
  a.localized = msg.status == liloc::init_result_t::STATUS_SUCCESS;
  a.method = msg.method;
  a.message = msg.message;
  a.keyframe_id = msg.keyframe_id;
  a.utime_us = msg.header.utime;
  a.T_map_body = from_msg(msg.pose);
  a.covariance = covariance_from_msg(msg.covariance);
  if (!a.covariance.allFinite()) {
    throw std::invalid_argument("init result: covariance not finite");
  }
  a.fitness_m = msg.fitness;
  a.descriptor_distance = msg.descriptor_distance;
  a.matched_submap_id = msg.matched_submap_id;
  a.matched_keyframe_id = msg.matched_keyframe_id;
  a.time_ms = msg.time_ms;
  return a;
}

CoarsePose coarse_pose_from_msg(const liloc::pose_t& msg) {
  const Eigen::Isometry3d T = from_msg(msg.pose);
  const Matrix6d covariance = covariance_from_msg(msg.covariance);
  if (!covariance.allFinite()) {
    throw std::invalid_argument("coarse pose: covariance not finite");
  }
  CoarsePose c;
  c.x_m = T.translation().x();
  c.y_m = T.translation().y();
  c.yaw_rad = so3::yaw(T.linear());
  c.sigma_xy_m = std::sqrt(std::max(covariance(0, 0), covariance(1, 1)));
  c.sigma_yaw_rad = std::sqrt(covariance(5, 5));
  return c;
}

liloc::pose_t to_msg(const CoarsePose& c, int64_t utime, const std::string& robot_id) {
  liloc::pose_t msg;
  msg.header = make_header(utime, robot_id, "map");
  msg.child_frame_id = "body";
  msg.pose = to_msg(
      se3::make(so3::exp(Eigen::Vector3d(0, 0, c.yaw_rad)), Eigen::Vector3d(c.x_m, c.y_m, 0.0)));
  Matrix6d covariance = Matrix6d::Zero();
  covariance.diagonal() << c.sigma_xy_m * c.sigma_xy_m, c.sigma_xy_m * c.sigma_xy_m, 100.0, 1.0,
      1.0, c.sigma_yaw_rad * c.sigma_yaw_rad;
  to_msg(covariance, msg.covariance);
  return msg;
}

InitQuery init_query_from_msg(const liloc::keyframe_t& msg) {
  InitQuery query;
  query.keyframe_id = msg.keyframe_id;
  query.utime_us = msg.header.utime;
  query.T_odom_body = from_msg(msg.pose);
  query.cloud_body = from_msg(msg.cloud);
  return query;
}

}  // namespace liloc::bridge
