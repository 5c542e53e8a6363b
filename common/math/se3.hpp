#pragma once
// SE(3) helpers on Eigen::Isometry3d. Tangent vectors are ordered
// (translation rho [m], rotation phi [rad]), the order of every covariance in liloc.
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

// Pose at fraction alpha in [0, 1] between T_a (alpha = 0) and T_b (alpha = 1):
// rotation along the geodesic, translation linear. This is the interpolation that
// deskewing and trajectory sampling use; for small motions it equals the SE(3) geodesic.
Eigen::Isometry3d interpolate(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b,
                              double alpha);

// Rotation angle of T in radians, in [0, pi].
double rotation_angle(const Eigen::Isometry3d& T);

}  // namespace liloc::se3
