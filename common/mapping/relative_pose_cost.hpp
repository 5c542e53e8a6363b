#pragma once
// Cost of one pose-graph edge: the measured relative pose T_ab_meas between nodes a and
// b against the estimate T_ab = T_a^-1 T_b, as the right perturbation that takes the
// measurement onto the estimate, T_ab = T_ab_meas Exp(xi) (math/se3.hpp), whitened by the
// edge's information over that same perturbation:
//   xi ~= [ R_ab_meas^T (R_a^T (p_b - p_a) - p_ab_meas) ;  2 vec(q_ab_meas^-1 q_a^-1 q_b) ]
// (to first order: translation in b's frame, rotation as twice the quaternion's vector
// part, the small-angle rotation vector). Positions and Eigen quaternions are the
// parameter blocks.

#include <ceres/autodiff_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "math/se3.hpp"

namespace liloc {

class RelativePoseCost {
 public:
  RelativePoseCost(const Eigen::Isometry3d& T_ab_measured, const Matrix6d& sqrt_information)
      : p_ab_(T_ab_measured.translation()),
        q_ab_(Eigen::Quaterniond(T_ab_measured.linear()).normalized()),
        sqrt_information_(sqrt_information) {}

  template <class T>
  bool operator()(const T* p_a_ptr, const T* q_a_ptr, const T* p_b_ptr, const T* q_b_ptr,
                  T* residual_ptr) const {
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> p_a(p_a_ptr);
    const Eigen::Map<const Eigen::Quaternion<T>> q_a(q_a_ptr);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> p_b(p_b_ptr);
    const Eigen::Map<const Eigen::Quaternion<T>> q_b(q_b_ptr);
    const Eigen::Quaternion<T> q_a_inverse = q_a.conjugate();
    const Eigen::Quaternion<T> q_ab = q_a_inverse * q_b;
    const Eigen::Matrix<T, 3, 1> p_ab = q_a_inverse * (p_b - p_a);
    const Eigen::Quaternion<T> q_measured_inverse = q_ab_.template cast<T>().conjugate();
    const Eigen::Quaternion<T> dq = q_measured_inverse * q_ab;
    Eigen::Map<Eigen::Matrix<T, 6, 1>> residual(residual_ptr);
    residual.template head<3>() = q_measured_inverse * (p_ab - p_ab_.template cast<T>());
    residual.template tail<3>() = T(2.0) * dq.vec();
    residual.applyOnTheLeft(sqrt_information_.template cast<T>());
    return true;
  }

  static ceres::CostFunction* create(const Eigen::Isometry3d& T_ab_measured,
                                     const Matrix6d& sqrt_information) {
    return new ceres::AutoDiffCostFunction<RelativePoseCost, 6, 3, 4, 3, 4>(
        new RelativePoseCost(T_ab_measured, sqrt_information));
  }

 private:
  Eigen::Vector3d p_ab_;
  Eigen::Quaterniond q_ab_;
  Matrix6d sqrt_information_;
};

}  // namespace liloc
