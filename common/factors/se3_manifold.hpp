#pragma once
// Poses as Ceres parameter blocks, perturbed on the right as everywhere in liloc
// (math/se3.hpp): a block is [p (3); q (4: x, y, z, w, Eigen's order)] and
// T [+] (rho, phi) = T Exp(rho, phi). Ceres' own quaternion manifolds perturb on the left;
// this one keeps the factors, their information matrices and the marginal priors in the
// convention of the covariances the odometry and the registration report.

#include <ceres/manifold.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>

namespace liloc {

using PoseBlock = std::array<double, 7>;

PoseBlock pose_block(const Eigen::Isometry3d& T);
Eigen::Isometry3d pose_of(const double* block);

class Se3Manifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 7; }
  int TangentSize() const override { return 6; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  // d(x [+] delta) / d delta at delta = 0: 7 x 6, row-major.
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  // d(y [-] x) / dy at y = x: 6 x 7, row-major; a left inverse of PlusJacobian.
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

// A block's tangent Jacobian from its ambient one (J_ambient * PlusJacobian), and back
// (J_tangent * MinusJacobian), for blocks of either kind: a pose (7 -> 6) or a vector.
Eigen::MatrixXd tangent_jacobian(const Eigen::MatrixXd& J_ambient, const double* x, bool pose);
Eigen::MatrixXd ambient_jacobian(const Eigen::MatrixXd& J_tangent, const double* x, bool pose);

}  // namespace liloc
