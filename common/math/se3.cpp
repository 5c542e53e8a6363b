#include "math/se3.hpp"

#include <cmath>

#include "math/so3.hpp"

namespace liloc::se3 {
namespace {
constexpr double kSmallAngle = 1e-7;

// V(phi) of the SE(3) exponential (left Jacobian of SO(3)).
Eigen::Matrix3d left_jacobian(const Eigen::Vector3d& phi) {
  const double theta = phi.norm();
  const Eigen::Matrix3d W = so3::hat(phi);
  if (theta < kSmallAngle) {
    return Eigen::Matrix3d::Identity() + 0.5 * W + W * W / 6.0;
  }
  const double t2 = theta * theta;
  return Eigen::Matrix3d::Identity() + ((1.0 - std::cos(theta)) / t2) * W +
         ((theta - std::sin(theta)) / (t2 * theta)) * W * W;
}

Eigen::Matrix3d left_jacobian_inverse(const Eigen::Vector3d& phi) {
  // J_l^-1(phi) = J_r^-1(-phi).
  return so3::right_jacobian_inverse(-phi);
}
}  // namespace

Eigen::Isometry3d make(const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = t;
  return T;
}

Eigen::Isometry3d make(const Eigen::Quaterniond& q, const Eigen::Vector3d& t) {
  return make(q.normalized().toRotationMatrix(), t);
}

Eigen::Isometry3d exp(const Vector6d& xi) {
  const Eigen::Vector3d rho = xi.head<3>();
  const Eigen::Vector3d phi = xi.tail<3>();
  return make(so3::exp(phi), left_jacobian(phi) * rho);
}

Vector6d log(const Eigen::Isometry3d& T) {
  const Eigen::Vector3d phi = so3::log(T.linear());
  Vector6d xi;
  xi.head<3>() = left_jacobian_inverse(phi) * T.translation();
  xi.tail<3>() = phi;
  return xi;
}

Eigen::Isometry3d plus(const Eigen::Isometry3d& T, const Vector6d& xi) {
  const Eigen::Isometry3d T_new = T * exp(xi);
  return make(so3::normalize(T_new.linear()), T_new.translation());
}

Vector6d minus(const Eigen::Isometry3d& T, const Eigen::Isometry3d& T_ref) {
  return log(T_ref.inverse() * T);
}

Eigen::Isometry3d interpolate(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b,
                              double alpha) {
  const Eigen::Matrix3d R_a = T_a.linear();
  const Eigen::Vector3d dphi = so3::log(R_a.transpose() * T_b.linear());
  return make(R_a * so3::exp(alpha * dphi),
              (1.0 - alpha) * T_a.translation() + alpha * T_b.translation());
}

double rotation_angle(const Eigen::Isometry3d& T) { return so3::log(T.linear()).norm(); }

}  // namespace liloc::se3
