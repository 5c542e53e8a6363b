#pragma once
// A Gaussian prior on one pose block (Se3Manifold): the anchor of a session in the map
// frame, and the prior nodes of the central session (held by their map poses, tighter than
// the robot's anchor). The residual is minus(T, T_prior) to first order (math/se3.hpp),
//   xi ~= [ R_prior^T (p - p_prior) ;  2 vec(q_prior^-1 q) ],
// whitened by the prior's information over that perturbation.

#include <ceres/autodiff_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "math/se3.hpp"

namespace liloc {

class PosePriorFactor {
 public:
  PosePriorFactor(const Eigen::Isometry3d& T_prior, const Matrix6d& sqrt_information)
      : p_(T_prior.translation()),
        q_(Eigen::Quaterniond(T_prior.linear()).normalized()),
        sqrt_information_(sqrt_information) {}

  template <class T>
  bool operator()(const T* pose, T* residual_ptr) const {
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> p(pose);
    const Eigen::Map<const Eigen::Quaternion<T>> q(pose + 3);
    const Eigen::Quaternion<T> q_prior_inverse = q_.template cast<T>().conjugate();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> residual(residual_ptr);
    residual.template head<3>() = q_prior_inverse * (p - p_.template cast<T>());
    residual.template tail<3>() = T(2.0) * (q_prior_inverse * q).vec();
    residual.applyOnTheLeft(sqrt_information_.template cast<T>());
    return true;
  }

  static ceres::CostFunction* create(const Eigen::Isometry3d& T_prior,
                                     const Matrix6d& sqrt_information) {
    return new ceres::AutoDiffCostFunction<PosePriorFactor, 6, 7>(
        new PosePriorFactor(T_prior, sqrt_information));
  }

 private:
  Eigen::Vector3d p_;
  Eigen::Quaterniond q_;
  Matrix6d sqrt_information_;
};

}  // namespace liloc
