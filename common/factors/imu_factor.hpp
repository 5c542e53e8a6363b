#pragma once
// The IMU factor between consecutive keyframes i and j (paper Eq. 5; the residuals of
// Forster et al., Section VI): the preintegrated increments, corrected to first order for the
// current bias estimate of i, against the states,
//   r_R = Log( dR(b_i)^T R_i^T R_j )                               (2 vec of the quaternion)
//   r_v = R_i^T (v_j - v_i - g dt) - dv(b_i)                       (g: the map's gravity)
//   r_p = R_i^T (p_j - p_i - v_i dt - g dt^2 / 2) - dp(b_i)
//   r_b = b_j - b_i                                                 (the biases' random walk)
// whitened by the preintegration's covariance and the random walk's over dt. Blocks: pose_i
// (Se3Manifold), v_i [m/s, map frame], b_i [accelerometer; gyroscope], pose_j, v_j, b_j,
// and the map frame's tilt (roll, pitch [rad]): g = Rx(roll) Ry(pitch) (0, 0, -|g|). A map
// built from a drive with an IMU has its z axis up (mapping/pose_graph_optimizer.hpp); one
// built without (LiDAR-only, imported poses, another tool) may be tilted by a degree or so,
// and assuming its z axis to be exactly up pulled the poses' roll and pitch by that much,
// so the tilt is estimated with them.

#include <ceres/autodiff_cost_function.h>
#include <ceres/rotation.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>

#include "factors/imu_preintegration.hpp"

namespace liloc {

class ImuFactor {
 public:
  ImuFactor(const ImuPreintegration& preintegration, double gravity_mps2)
      : dt_(preintegration.dt_s()),
        bias_(preintegration.bias()),
        dq_(Eigen::Quaterniond(preintegration.delta_R()).normalized()),
        dv_(preintegration.delta_v()),
        dp_(preintegration.delta_p()),
        dR_dbg_(preintegration.dR_dbg()),
        dv_dba_(preintegration.dv_dba()),
        dv_dbg_(preintegration.dv_dbg()),
        dp_dba_(preintegration.dp_dba()),
        dp_dbg_(preintegration.dp_dbg()),
        gravity_mps2_(gravity_mps2) {
    Eigen::Matrix<double, 15, 15> covariance = Eigen::Matrix<double, 15, 15>::Zero();
    covariance.topLeftCorner<9, 9>() = preintegration.covariance();
    const double dt = std::max(dt_, 1e-3);
    covariance.block<3, 3>(9, 9).diagonal().setConstant(preintegration.accel_bias_variance_rate() *
                                                        dt);
    covariance.block<3, 3>(12, 12).diagonal().setConstant(preintegration.gyro_bias_variance_rate() *
                                                          dt);
    // A floor keeps the information finite for a near-empty integration.
    covariance.diagonal().array() += 1e-12;
    Eigen::Matrix<double, 15, 15> information = covariance.inverse();
    information = 0.5 * (information + information.transpose());
    sqrt_information_ =
        Eigen::LLT<Eigen::Matrix<double, 15, 15>>(information).matrixL().transpose();
  }

  template <class T>
  bool operator()(const T* pose_i, const T* v_i_ptr, const T* b_i, const T* pose_j,
                  const T* v_j_ptr, const T* b_j, const T* tilt, T* residual_ptr) const {
    using Vec3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Vec3> p_i(pose_i), p_j(pose_j), v_i(v_i_ptr), v_j(v_j_ptr);
    const Eigen::Map<const Eigen::Quaternion<T>> q_i(pose_i + 3), q_j(pose_j + 3);
    const Eigen::Map<const Vec3> ba_i(b_i), bg_i(b_i + 3), ba_j(b_j), bg_j(b_j + 3);
    const Vec3 dba = ba_i - bias_.accel_mps2.template cast<T>();
    const Vec3 dbg = bg_i - bias_.gyro_rps.template cast<T>();
    // dR(b_i) = dR Exp(dR/dbg dbg).
    const Vec3 correction = dR_dbg_.template cast<T>() * dbg;
    T q_correction_wxyz[4];
    ceres::AngleAxisToQuaternion(correction.data(), q_correction_wxyz);
    const Eigen::Quaternion<T> q_correction(q_correction_wxyz[0], q_correction_wxyz[1],
                                            q_correction_wxyz[2], q_correction_wxyz[3]);
    const Eigen::Quaternion<T> dq = dq_.template cast<T>() * q_correction;
    const Vec3 dv = dv_.template cast<T>() + dv_dba_.template cast<T>() * dba +
                    dv_dbg_.template cast<T>() * dbg;
    const Vec3 dp = dp_.template cast<T>() + dp_dba_.template cast<T>() * dba +
                    dp_dbg_.template cast<T>() * dbg;
    const Eigen::Quaternion<T> q_i_inverse = q_i.conjugate();
    const T dt(dt_);
    using std::cos;
    using std::sin;
    const T gravity(gravity_mps2_);
    const Vec3 g(-gravity * sin(tilt[1]), gravity * cos(tilt[1]) * sin(tilt[0]),
                 -gravity * cos(tilt[1]) * cos(tilt[0]));
    Eigen::Map<Eigen::Matrix<T, 15, 1>> r(residual_ptr);
    r.template segment<3>(0) = T(2.0) * (dq.conjugate() * (q_i_inverse * q_j)).vec();
    r.template segment<3>(3) = q_i_inverse * (v_j - v_i - g * dt) - dv;
    r.template segment<3>(6) = q_i_inverse * (p_j - p_i - v_i * dt - T(0.5) * g * dt * dt) - dp;
    r.template segment<3>(9) = ba_j - ba_i;
    r.template segment<3>(12) = bg_j - bg_i;
    r.applyOnTheLeft(sqrt_information_.template cast<T>());
    return true;
  }

  static ceres::CostFunction* create(const ImuPreintegration& preintegration, double gravity_mps2) {
    return new ceres::AutoDiffCostFunction<ImuFactor, 15, 7, 3, 6, 7, 3, 6, 2>(
        new ImuFactor(preintegration, gravity_mps2));
  }

 private:
  double dt_;
  ImuBias bias_;
  Eigen::Quaterniond dq_;
  Eigen::Vector3d dv_, dp_;
  Eigen::Matrix3d dR_dbg_, dv_dba_, dv_dbg_, dp_dba_, dp_dbg_;
  double gravity_mps2_;
  Eigen::Matrix<double, 15, 15> sqrt_information_;
};

}  // namespace liloc
