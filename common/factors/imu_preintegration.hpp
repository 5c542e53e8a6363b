#pragma once
// On-manifold IMU preintegration between two keyframes (Forster et al., "On-Manifold
// Preintegration for Real-Time Visual-Inertial Odometry", 2017; the paper's Eq. 5): the
// rotation, velocity and position increments in keyframe i's body frame, independent of
// the states, their covariance, and their Jacobians with respect to the biases, so that a
// new bias estimate corrects the increments to first order instead of integrating again.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "imu/imu_noise.hpp"
#include "imu/imu_sample.hpp"

namespace liloc {

using Matrix9d = Eigen::Matrix<double, 9, 9>;
using Vector15d = Eigen::Matrix<double, 15, 1>;

struct ImuBias {
  Eigen::Vector3d accel_mps2 = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_rps = Eigen::Vector3d::Zero();
};

class ImuPreintegration {
 public:
  // Integrates from `bias` (the linearization point of the bias Jacobians).
  ImuPreintegration(const ImuBias& bias, const ImuNoiseDensities& noise);

  // One measurement held over dt_s.
  void integrate(const Eigen::Vector3d& accel_mps2, const Eigen::Vector3d& gyro_rps, double dt_s);
  // The samples' measurements over [t_from_us, t_to_us], linear between samples (the one at
  // or before t_from_us covers the start, the last one is held to the end). Returns the
  // longest time without a sample, in seconds (an IMU gap the caller may refuse).
  double integrate(const std::vector<ImuSample>& samples, int64_t t_from_us, int64_t t_to_us);

  double dt_s() const { return dt_s_; }
  const ImuBias& bias() const { return bias_; }
  // Increments at the integration's bias, and corrected to first order for another.
  const Eigen::Matrix3d& delta_R() const { return dR_; }
  const Eigen::Vector3d& delta_v() const { return dv_; }
  const Eigen::Vector3d& delta_p() const { return dp_; }
  Eigen::Matrix3d delta_R(const ImuBias& bias) const;
  Eigen::Vector3d delta_v(const ImuBias& bias) const;
  Eigen::Vector3d delta_p(const ImuBias& bias) const;
  // Covariance of (rotation [right perturbation of delta_R], velocity, position).
  const Matrix9d& covariance() const { return covariance_; }
  // Variance per second of each bias's random walk (accelerometer, gyroscope).
  double accel_bias_variance_rate() const;
  double gyro_bias_variance_rate() const;

  // Jacobians of the increments with respect to the biases (Forster et al. Appendix B).
  const Eigen::Matrix3d& dR_dbg() const { return dR_dbg_; }
  const Eigen::Matrix3d& dv_dba() const { return dv_dba_; }
  const Eigen::Matrix3d& dv_dbg() const { return dv_dbg_; }
  const Eigen::Matrix3d& dp_dba() const { return dp_dba_; }
  const Eigen::Matrix3d& dp_dbg() const { return dp_dbg_; }

 private:
  ImuBias bias_;
  ImuNoiseDensities noise_;
  double dt_s_ = 0.0;
  Eigen::Matrix3d dR_ = Eigen::Matrix3d::Identity();
  Eigen::Vector3d dv_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d dp_ = Eigen::Vector3d::Zero();
  Matrix9d covariance_ = Matrix9d::Zero();
  Eigen::Matrix3d dR_dbg_ = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d dv_dba_ = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d dv_dbg_ = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d dp_dba_ = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d dp_dbg_ = Eigen::Matrix3d::Zero();
};

}  // namespace liloc
