#include "odometry/navigation_state.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "math/se3.hpp"
#include "math/so3.hpp"

namespace liloc {

Eigen::Matrix<double, 3, 2> gravity_tangent_basis(const Eigen::Vector3d& g) {
  const Eigen::Vector3d u = g.normalized();
  // Any vector not parallel to u seeds the basis.
  const Eigen::Vector3d seed =
      std::abs(u.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  Eigen::Matrix<double, 3, 2> B;
  B.col(0) = u.cross(seed).normalized();
  B.col(1) = u.cross(B.col(0));
  return B;
}

Eigen::Matrix<double, 3, 2> gravity_jacobian(const Eigen::Vector3d& g) {
  return -g.norm() * so3::hat(g.normalized()) * gravity_tangent_basis(g);
}

BodyGravity body_gravity(const NavState& x, const StateMatrix& P) {
  BodyGravity out;
  const Eigen::Vector3d u = x.g.normalized();
  out.direction = x.R.transpose() * u;
  // d/d(phi, dg) of R^T u, with R = R_hat Exp(phi) and u = Exp(B dg) u_hat to first order.
  Eigen::Matrix<double, 3, 5> J;
  J.leftCols<3>() = so3::hat(out.direction);
  J.rightCols<2>() = x.R.transpose() * gravity_jacobian(x.g) / x.g.norm();
  Eigen::Matrix<double, 5, 5> S;
  S << P.block<3, 3>(kRot, kRot), P.block<3, 2>(kRot, kGrav), P.block<2, 3>(kGrav, kRot),
      P.block<2, 2>(kGrav, kGrav);
  const Eigen::Matrix3d C = J * S * J.transpose();
  out.sigma_rad =
      std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(C).eigenvalues()(2)));
  return out;
}

NavState boxplus(const NavState& x, const StateVector& dx) {
  NavState y;
  const Eigen::Isometry3d T = se3::plus(se3::make(x.R, x.p), dx.head<6>());
  y.R = T.linear();
  y.p = T.translation();
  y.v = x.v + dx.segment<3>(kVel);
  y.bg = x.bg + dx.segment<3>(kBg);
  y.ba = x.ba + dx.segment<3>(kBa);
  const Eigen::Vector3d tangent = gravity_tangent_basis(x.g) * dx.segment<2>(kGrav);
  y.g = x.g.norm() * (so3::exp(tangent) * x.g.normalized());
  return y;
}

StateVector boxminus(const NavState& y, const NavState& x) {
  StateVector dx;
  dx.head<6>() = se3::minus(se3::make(y.R, y.p), se3::make(x.R, x.p));
  dx.segment<3>(kVel) = y.v - x.v;
  dx.segment<3>(kBg) = y.bg - x.bg;
  dx.segment<3>(kBa) = y.ba - x.ba;
  // The tangent of S2 at x.g that rotates it onto y.g.
  const Eigen::Vector3d u = x.g.normalized();
  const Eigen::Vector3d axis =
      so3::log(Eigen::Quaterniond::FromTwoVectors(u, y.g.normalized()).toRotationMatrix());
  dx.segment<2>(kGrav) = gravity_tangent_basis(x.g).transpose() * axis;
  return dx;
}

}  // namespace liloc
