#include "bridge/odometry_conversions.hpp"

#include <stdexcept>

#include "bridge/lcm_conversions.hpp"

namespace liloc::bridge {
namespace {
void put(const Eigen::Vector3d& v, double (&out)[3]) {
  for (int i = 0; i < 3; ++i) {
    out[i] = v[i];
  }
}

Eigen::Vector3d finite_vector(const double (&v)[3], const char* message, const char* field) {
  const Eigen::Vector3d out(v[0], v[1], v[2]);
  if (!out.allFinite()) {
    throw std::invalid_argument(std::string(message) + ": " + field + " is not finite");
  }
  return out;
}
}  // namespace

liloc::odometry_t to_msg(const OdometryEstimate& e, const OdometryFrames& frames) {
  liloc::odometry_t msg;
  msg.header = make_header(e.utime_us, frames.robot_id, frames.odom_frame);
  msg.child_frame_id = frames.body_frame;
  msg.pose = to_msg(e.T_odom_body);
  put(e.velocity_odom, msg.linear_velocity);
  put(e.angular_velocity_body, msg.angular_velocity);
  to_msg(e.covariance, msg.covariance);
  put(e.gyro_bias, msg.gyro_bias);
  put(e.accel_bias, msg.accel_bias);
  return msg;
}

OdometryEstimate from_msg(const liloc::odometry_t& msg) {
  OdometryEstimate e;
  e.utime_us = msg.header.utime;
  e.T_odom_body = from_msg(msg.pose);
  e.velocity_odom = finite_vector(msg.linear_velocity, "odometry", "linear_velocity");
  e.angular_velocity_body = finite_vector(msg.angular_velocity, "odometry", "angular_velocity");
  e.gyro_bias = finite_vector(msg.gyro_bias, "odometry", "gyro_bias");
  e.accel_bias = finite_vector(msg.accel_bias, "odometry", "accel_bias");
  e.covariance = covariance_from_msg(msg.covariance);
  if (!e.covariance.allFinite()) {
    throw std::invalid_argument("odometry: covariance is not finite");
  }
  return e;
}

liloc::keyframe_t to_msg(const Keyframe& kf, const OdometryFrames& frames) {
  liloc::keyframe_t msg;
  msg.header = make_header(kf.utime_us, frames.robot_id, frames.odom_frame);
  msg.keyframe_id = kf.id;
  msg.child_frame_id = frames.body_frame;
  msg.pose = to_msg(kf.T_odom_body);
  put(kf.velocity_odom, msg.linear_velocity);
  put(kf.gyro_bias, msg.gyro_bias);
  put(kf.accel_bias, msg.accel_bias);
  to_msg(kf.covariance, msg.covariance);
  msg.fitness = static_cast<float>(kf.fitness_m);
  msg.degenerate = kf.degenerate;
  put(kf.gravity_body, msg.gravity_body);
  msg.gravity_sigma = static_cast<float>(kf.gravity_sigma_rad);
  msg.cloud = to_msg(kf.cloud_body);
  return msg;
}

Keyframe from_msg(const liloc::keyframe_t& msg, size_t* non_finite_points) {
  Keyframe kf;
  kf.id = msg.keyframe_id;
  kf.utime_us = msg.header.utime;
  kf.T_odom_body = from_msg(msg.pose);
  kf.velocity_odom = Eigen::Vector3d(msg.linear_velocity);
  kf.gyro_bias = Eigen::Vector3d(msg.gyro_bias);
  kf.accel_bias = Eigen::Vector3d(msg.accel_bias);
  kf.covariance = covariance_from_msg(msg.covariance);
  kf.fitness_m = msg.fitness;
  kf.degenerate = msg.degenerate;
  kf.gravity_body = Eigen::Vector3d(msg.gravity_body);
  kf.gravity_sigma_rad = msg.gravity_sigma;
  kf.cloud_body = from_msg(msg.cloud, non_finite_points);
  return kf;
}

OdometryCorrection from_msg(const liloc::correction_t& msg) {
  OdometryCorrection c;
  c.utime_us = msg.header.utime;
  if (msg.has_pose) {
    c.T_odom_body = from_msg(msg.pose);
  }
  if (msg.has_velocity) {
    c.velocity_odom = finite_vector(msg.linear_velocity, "correction", "linear_velocity");
  }
  if (msg.has_bias) {
    c.gyro_bias = finite_vector(msg.gyro_bias, "correction", "gyro_bias");
    c.accel_bias = finite_vector(msg.accel_bias, "correction", "accel_bias");
  }
  return c;
}

}  // namespace liloc::bridge
