#pragma once
// SO(3) on rotation matrices: hat, Exp/Log and the right Jacobians used by on-manifold
// optimization (Forster et al., "On-Manifold Preintegration", Eqs. 3-8).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace liloc::so3 {

inline constexpr double kRadToDeg = 180.0 / M_PI;

// [v]x: the skew-symmetric matrix with hat(a) * b = a.cross(b).
Eigen::Matrix3d hat(const Eigen::Vector3d& v);

// Rodrigues' formula; exact to first order near zero.
Eigen::Matrix3d exp(const Eigen::Vector3d& phi_rad);

// Rotation vector of R, with norm in [0, pi]. Stable near 0 and near pi.
Eigen::Vector3d log(const Eigen::Matrix3d& R);

// Right Jacobian Jr(phi): Exp(phi + dphi) ~= Exp(phi) Exp(Jr(phi) dphi).
Eigen::Matrix3d right_jacobian(const Eigen::Vector3d& phi_rad);

// Inverse of the right Jacobian: Log(Exp(phi) Exp(dphi)) ~= phi + Jr^-1(phi) dphi.
Eigen::Matrix3d right_jacobian_inverse(const Eigen::Vector3d& phi_rad);

// R = Rz(yaw) Ry(pitch) Rx(roll): the roll-pitch-yaw convention of every config file.
Eigen::Matrix3d from_rpy(const Eigen::Vector3d& rpy_rad);

// Roll, pitch, yaw of R (the inverse of from_rpy; pitch in [-pi/2, pi/2]).
Eigen::Vector3d to_rpy(const Eigen::Matrix3d& R);

// Heading of R about the z axis (the yaw of from_rpy), in (-pi, pi].
double yaw(const Eigen::Matrix3d& R);

// Angle between R's z axis and the z axis (rad): how far R tilts what is up.
double tilt(const Eigen::Matrix3d& R);

// An angle wrapped to [-pi, pi].
double wrap_angle(double angle_rad);

// Projects a nearly orthonormal matrix (accumulated round-off) back onto SO(3).
Eigen::Matrix3d normalize(const Eigen::Matrix3d& R);

}  // namespace liloc::so3
