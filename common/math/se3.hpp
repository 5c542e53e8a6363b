#pragma once
// SE(3) helpers on Eigen::Isometry3d, and liloc's one tangent convention.
//
// Tangent vectors are xi = (rho [m], phi [rad]): translation first, rotation second, and
// they perturb a pose on the right, T = T_hat * Exp(xi) (plus / minus below). Every
// covariance, information matrix, pose prior and Jacobian in liloc uses this convention:
// registration, the odometry's filter, pose-graph edges, the optimizer's factors and the
// messages. To first order the translation part is the body (child) frame's: a pose
// T_a_b perturbed by xi moves its origin by R_a_b * rho in frame a.
// Naming: T_a_b maps points from frame b into frame a, so T_a_b * T_b_c = T_a_c.

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace liloc {
using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
}  // namespace liloc

namespace liloc::se3 {

Eigen::Isometry3d make(const Eigen::Matrix3d& R, const Eigen::Vector3d& t);
Eigen::Isometry3d make(const Eigen::Quaterniond& q, const Eigen::Vector3d& t);

// Exp: (rho, phi) -> [Exp(phi), V(phi) rho; 0, 1].
Eigen::Isometry3d exp(const Vector6d& xi);

// Log, the inverse of exp.
Vector6d log(const Eigen::Isometry3d& T);

// T [+] xi = T * Exp(xi), and its inverse: minus(T, T_ref) = Log(T_ref^-1 * T), so that
// plus(T_ref, minus(T, T_ref)) = T.
Eigen::Isometry3d plus(const Eigen::Isometry3d& T, const Vector6d& xi);
Vector6d minus(const Eigen::Isometry3d& T, const Eigen::Isometry3d& T_ref);

// Pose at fraction alpha in [0, 1] between T_a (alpha = 0) and T_b (alpha = 1):
// rotation along the geodesic, translation linear. This is the interpolation that
// deskewing and trajectory sampling use; for small motions it equals the SE(3) geodesic.
Eigen::Isometry3d interpolate(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b,
                              double alpha);

// Rotation angle of T in radians, in [0, pi].
double rotation_angle(const Eigen::Isometry3d& T);

}  // namespace liloc::se3
