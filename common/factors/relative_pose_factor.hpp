#pragma once
// A measured relative pose T_ab between two pose blocks a and b (Se3Manifold): pose-graph
// edges of the map builder, and in the optimizer the LiDAR odometry factor (paper Eq. 7)
// and the scan-match factors of the propagation model (Eq. 8). The residual is the right
// perturbation that takes the measurement onto the estimate T_ab = T_a^-1 T_b, to first
// order (math/se3.hpp),
//   xi ~= [ R_ab_meas^T (R_a^T (p_b - p_a) - p_ab_meas) ;  2 vec(q_ab_meas^-1 q_a^-1 q_b) ],
// whitened by the measurement's information over that same perturbation.

#include <ceres/autodiff_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "math/se3.hpp"
#include "math/so3.hpp"

namespace liloc {

// The Jacobian of the residual's perturbation of T_ab = T_a^-1 T_b by a's right
// perturbation d_a (b's is the identity): d_ab = J_a d_a + d_b to first order, with
// J_a = [ -R_ab^T   R_ab^T [p_ab]x ;  0   -R_ab^T ].
inline Matrix6d relative_pose_jacobian_a(const Eigen::Isometry3d& T_ab) {
  const Eigen::Matrix3d R_ba = T_ab.linear().transpose();
  Matrix6d J_a = Matrix6d::Zero();
  J_a.topLeftCorner<3, 3>() = -R_ba;
  J_a.topRightCorner<3, 3>() = R_ba * so3::hat(T_ab.translation());
  J_a.bottomRightCorner<3, 3>() = -R_ba;
  return J_a;
}

// The covariance of T_ab from both ends' covariances (right perturbations), taken as
// independent.
inline Matrix6d relative_pose_covariance(const Eigen::Isometry3d& T_ab,
                                         const Matrix6d& covariance_a,
                                         const Matrix6d& covariance_b) {
  const Matrix6d J_a = relative_pose_jacobian_a(T_ab);
  return J_a * covariance_a * J_a.transpose() + covariance_b;
}

class RelativePoseFactor {
 public:
  RelativePoseFactor(const Eigen::Isometry3d& T_ab_measured, const Matrix6d& sqrt_information)
      : p_ab_(T_ab_measured.translation()),
        q_ab_(Eigen::Quaterniond(T_ab_measured.linear()).normalized()),
        sqrt_information_(sqrt_information) {}

  template <class T>
  bool operator()(const T* a, const T* b, T* residual_ptr) const {
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> p_a(a);
    const Eigen::Map<const Eigen::Quaternion<T>> q_a(a + 3);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> p_b(b);
    const Eigen::Map<const Eigen::Quaternion<T>> q_b(b + 3);
    const Eigen::Quaternion<T> q_a_inverse = q_a.conjugate();
    const Eigen::Quaternion<T> q_measured_inverse = q_ab_.template cast<T>().conjugate();
    const Eigen::Quaternion<T> dq = q_measured_inverse * (q_a_inverse * q_b);
    Eigen::Map<Eigen::Matrix<T, 6, 1>> residual(residual_ptr);
    residual.template head<3>() =
        q_measured_inverse * (q_a_inverse * (p_b - p_a) - p_ab_.template cast<T>());
    residual.template tail<3>() = T(2.0) * dq.vec();
    residual.applyOnTheLeft(sqrt_information_.template cast<T>());
    return true;
  }

  static ceres::CostFunction* create(const Eigen::Isometry3d& T_ab_measured,
                                     const Matrix6d& sqrt_information) {
    return new ceres::AutoDiffCostFunction<RelativePoseFactor, 6, 7, 7>(
        new RelativePoseFactor(T_ab_measured, sqrt_information));
  }

 private:
  Eigen::Vector3d p_ab_;
  Eigen::Quaterniond q_ab_;
  Matrix6d sqrt_information_;
};

}  // namespace liloc
