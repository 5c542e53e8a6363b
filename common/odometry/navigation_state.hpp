#pragma once
// The odometry's state and its error-state parametrization (an iterated error-state
// Kalman filter, as in FAST-LIO2, with gravity on S2):
//   x = (T, v, bg, ba, g) with the pose T = (R, p) perturbed on the right,
//   T = T_hat Exp(rho, phi) (liloc's tangent convention, math/se3.hpp: translation in the
//   body frame, then rotation), v additive (local map frame), biases additive,
//   g = |g| Exp(B(u) dg) u with dg in the 2D tangent of S2.
// The pose block is thus what registration, pose priors and covariances on the wire use.
// Estimating the gravity direction lets a turn-on accelerometer bias be told apart from
// the initial tilt instead of being frozen into the map.

#include <Eigen/Core>

namespace liloc {

constexpr int kStateDim = 17;
constexpr int kPos = 0;    // rho, body frame
constexpr int kRot = 3;    // phi, body frame
constexpr int kVel = 6;    // dv, local map frame
constexpr int kBg = 9;     // gyro bias
constexpr int kBa = 12;    // accelerometer bias
constexpr int kGrav = 15;  // gravity direction, 2D
using StateVector = Eigen::Matrix<double, kStateDim, 1>;
using StateMatrix = Eigen::Matrix<double, kStateDim, kStateDim>;

struct NavState {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();   // R_local_body
  Eigen::Vector3d p = Eigen::Vector3d::Zero();       // m, local map frame
  Eigen::Vector3d v = Eigen::Vector3d::Zero();       // m/s, local map frame
  Eigen::Vector3d bg = Eigen::Vector3d::Zero();      // rad/s
  Eigen::Vector3d ba = Eigen::Vector3d::Zero();      // m/s^2
  Eigen::Vector3d g = Eigen::Vector3d(0, 0, -9.81);  // m/s^2, local map frame
};

// Orthonormal basis (3x2) of the plane tangent to S2 at direction g.
Eigen::Matrix<double, 3, 2> gravity_tangent_basis(const Eigen::Vector3d& g);

// d g / d dg at dg = 0: -|g| [u]x B(u).
Eigen::Matrix<double, 3, 2> gravity_jacobian(const Eigen::Vector3d& g);

// Gravity's direction in the body frame, R^T g / |g|, with the 1-sigma angle of its larger
// axis (rad) from the covariance P of the attitude and the gravity direction (their
// correlation included: what the filter knows is the tilt of the body against gravity).
struct BodyGravity {
  Eigen::Vector3d direction = Eigen::Vector3d::Zero();
  double sigma_rad = 0.0;
};
BodyGravity body_gravity(const NavState& x, const StateMatrix& P);

NavState boxplus(const NavState& x, const StateVector& dx);
// The inverse of boxplus: boxplus(x, boxminus(y, x)) = y.
StateVector boxminus(const NavState& y, const NavState& x);

}  // namespace liloc
