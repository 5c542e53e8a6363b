#pragma once
// Levels a pose by gravity: the map frame's down direction seen from the body, against the
// direction the odometry's filter measured in the body at that keyframe,
//   r = (R^T g_map - g_body) / sigma     (g_map, g_body unit vectors),
// to first order the tilt between them (rad) in the body frame. Rotation about gravity and
// the position stay free. The map builder adds one per keyframe with an IMU: loop closures
// make a map consistent in itself, gravity makes its attitude consistent with the IMU
// that localizes in it.

#include <ceres/autodiff_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace liloc {

class GravityFactor {
 public:
  GravityFactor(const Eigen::Vector3d& down_map, const Eigen::Vector3d& down_body, double sigma_rad)
      : down_map_(down_map.normalized()),
        down_body_(down_body.normalized()),
        inverse_sigma_(1.0 / sigma_rad) {}

  template <class T>
  bool operator()(const T* pose, T* residual_ptr) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(pose + 3);
    Eigen::Map<Eigen::Matrix<T, 3, 1>> residual(residual_ptr);
    residual = (q.conjugate() * down_map_.template cast<T>() - down_body_.template cast<T>()) *
               T(inverse_sigma_);
    return true;
  }

  static ceres::CostFunction* create(const Eigen::Vector3d& down_map,
                                     const Eigen::Vector3d& down_body, double sigma_rad) {
    return new ceres::AutoDiffCostFunction<GravityFactor, 3, 7>(
        new GravityFactor(down_map, down_body, sigma_rad));
  }

 private:
  Eigen::Vector3d down_map_;
  Eigen::Vector3d down_body_;
  double inverse_sigma_;
};

}  // namespace liloc
