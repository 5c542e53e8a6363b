#include "math/so3.hpp"

#include <algorithm>
#include <cmath>

namespace liloc::so3 {
namespace {
// Below this angle the series expansions are exact to double precision.
constexpr double kSmallAngle = 1e-7;
}  // namespace

Eigen::Matrix3d hat(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

Eigen::Matrix3d exp(const Eigen::Vector3d& phi_rad) {
  const double theta = phi_rad.norm();
  const Eigen::Matrix3d W = hat(phi_rad);
  if (theta < kSmallAngle) {
    return Eigen::Matrix3d::Identity() + W + 0.5 * W * W;
  }
  return Eigen::Matrix3d::Identity() + (std::sin(theta) / theta) * W +
         ((1.0 - std::cos(theta)) / (theta * theta)) * W * W;
}

Eigen::Vector3d log(const Eigen::Matrix3d& R) {
  // The quaternion route is stable at both ends of [0, pi], unlike acos((tr - 1) / 2).
  Eigen::Quaterniond q(R);
  q.normalize();
  if (q.w() < 0.0) {
    q.coeffs() *= -1.0;  // the shorter of the two rotations
  }
  const Eigen::Vector3d v = q.vec();
  const double s = v.norm();
  if (s < kSmallAngle) {
    return 2.0 * v / q.w();
  }
  const double theta = 2.0 * std::atan2(s, q.w());
  return (theta / s) * v;
}

Eigen::Matrix3d right_jacobian(const Eigen::Vector3d& phi_rad) {
  const double theta = phi_rad.norm();
  const Eigen::Matrix3d W = hat(phi_rad);
  if (theta < kSmallAngle) {
    return Eigen::Matrix3d::Identity() - 0.5 * W + W * W / 6.0;
  }
  const double t2 = theta * theta;
  return Eigen::Matrix3d::Identity() - ((1.0 - std::cos(theta)) / t2) * W +
         ((theta - std::sin(theta)) / (t2 * theta)) * W * W;
}

Eigen::Matrix3d right_jacobian_inverse(const Eigen::Vector3d& phi_rad) {
  const double theta = phi_rad.norm();
  const Eigen::Matrix3d W = hat(phi_rad);
  if (theta < kSmallAngle) {
    return Eigen::Matrix3d::Identity() + 0.5 * W + W * W / 12.0;
  }
  const double t2 = theta * theta;
  return Eigen::Matrix3d::Identity() + 0.5 * W +
         (1.0 / t2 - (1.0 + std::cos(theta)) / (2.0 * theta * std::sin(theta))) * W * W;
}

Eigen::Matrix3d from_rpy(const Eigen::Vector3d& rpy_rad) {
  return (Eigen::AngleAxisd(rpy_rad.z(), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(rpy_rad.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy_rad.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Vector3d to_rpy(const Eigen::Matrix3d& R) {
  return {std::atan2(R(2, 1), R(2, 2)), std::asin(std::clamp(-R(2, 0), -1.0, 1.0)),
          std::atan2(R(1, 0), R(0, 0))};
}

double yaw(const Eigen::Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); }

double tilt(const Eigen::Matrix3d& R) { return std::acos(std::clamp(R(2, 2), -1.0, 1.0)); }

double wrap_angle(double angle_rad) { return std::remainder(angle_rad, 2.0 * M_PI); }

Eigen::Matrix3d normalize(const Eigen::Matrix3d& R) {
  return Eigen::Quaterniond(R).normalized().toRotationMatrix();
}

}  // namespace liloc::so3
