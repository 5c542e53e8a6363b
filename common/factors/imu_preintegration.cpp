#include "factors/imu_preintegration.hpp"

#include <algorithm>
#include <stdexcept>

#include "math/so3.hpp"

namespace liloc {

ImuPreintegration::ImuPreintegration(const ImuBias& bias, const ImuNoiseDensities& noise)
    : bias_(bias), noise_(noise) {
  noise_.validate();
}

void ImuPreintegration::integrate(const Eigen::Vector3d& accel_mps2,
                                  const Eigen::Vector3d& gyro_rps, double dt_s) {
  if (!(dt_s >= 0.0)) {
    throw std::invalid_argument("preintegration over a negative time step");
  }
  if (dt_s == 0.0) {
    return;
  }
  const Eigen::Vector3d a = accel_mps2 - bias_.accel_mps2;
  const Eigen::Vector3d w = gyro_rps - bias_.gyro_rps;
  const Eigen::Matrix3d dR_k = so3::exp(w * dt_s);
  const Eigen::Matrix3d Jr_k = so3::right_jacobian(w * dt_s);
  const Eigen::Matrix3d a_hat = so3::hat(a);
  const double dt2 = dt_s * dt_s;
  // Covariance (Forster et al. Eq. 62): rotation, velocity, position.
  Matrix9d A = Matrix9d::Identity();
  A.block<3, 3>(0, 0) = dR_k.transpose();
  A.block<3, 3>(3, 0) = -dR_ * a_hat * dt_s;
  A.block<3, 3>(6, 0) = -0.5 * dR_ * a_hat * dt2;
  A.block<3, 3>(6, 3) = Eigen::Matrix3d::Identity() * dt_s;
  Eigen::Matrix<double, 9, 3> B_gyro = Eigen::Matrix<double, 9, 3>::Zero();
  Eigen::Matrix<double, 9, 3> B_accel = Eigen::Matrix<double, 9, 3>::Zero();
  B_gyro.topRows<3>() = Jr_k * dt_s;
  B_accel.middleRows<3>(3) = dR_ * dt_s;
  B_accel.bottomRows<3>() = 0.5 * dR_ * dt2;
  // Discrete noise of a sample held over dt: density^2 / dt.
  const double gyro_var = noise_.gyro_noise_density * noise_.gyro_noise_density / dt_s;
  const double accel_var = noise_.accel_noise_density * noise_.accel_noise_density / dt_s;
  covariance_ = A * covariance_ * A.transpose() + gyro_var * B_gyro * B_gyro.transpose() +
                accel_var * B_accel * B_accel.transpose();
  // Bias Jacobians (Forster et al. Appendix B), before the increments move on.
  dp_dba_ += dv_dba_ * dt_s - 0.5 * dR_ * dt2;
  dp_dbg_ += dv_dbg_ * dt_s - 0.5 * dR_ * a_hat * dR_dbg_ * dt2;
  dv_dba_ -= dR_ * dt_s;
  dv_dbg_ -= dR_ * a_hat * dR_dbg_ * dt_s;
  dR_dbg_ = dR_k.transpose() * dR_dbg_ - Jr_k * dt_s;
  // Increments.
  dp_ += dv_ * dt_s + 0.5 * dR_ * a * dt2;
  dv_ += dR_ * a * dt_s;
  dR_ = so3::normalize(dR_ * dR_k);
  dt_s_ += dt_s;
}

double ImuPreintegration::integrate(const std::vector<ImuSample>& samples, int64_t t_from_us,
                                    int64_t t_to_us) {
  if (t_to_us < t_from_us) {
    throw std::invalid_argument("preintegration backwards in time");
  }
  if (samples.empty()) {
    throw std::invalid_argument("preintegration needs at least one IMU sample");
  }
  // The measurements between two samples are taken to vary linearly (held before the first
  // and after the last); each piece is integrated at its midpoint, which on a simulated
  // drive is two orders of magnitude closer to the truth than holding each sample.
  const auto at = [&](size_t k, int64_t t) -> std::pair<Eigen::Vector3d, Eigen::Vector3d> {
    const ImuSample& a = samples[k];
    if (k + 1 >= samples.size() || t <= a.utime_us) {
      return {a.accel_mps2, a.gyro_rps};
    }
    const ImuSample& b = samples[k + 1];
    const double alpha = std::min(
        1.0, static_cast<double>(t - a.utime_us) / static_cast<double>(b.utime_us - a.utime_us));
    return {a.accel_mps2 + alpha * (b.accel_mps2 - a.accel_mps2),
            a.gyro_rps + alpha * (b.gyro_rps - a.gyro_rps)};
  };
  // The sample at or before the start (or the first one).
  auto it = std::upper_bound(samples.begin(), samples.end(), t_from_us,
                             [](int64_t t, const ImuSample& s) { return t < s.utime_us; });
  size_t k = it == samples.begin() ? 0 : static_cast<size_t>(it - samples.begin()) - 1;
  double longest_gap_s = samples.front().utime_us > t_from_us
                             ? static_cast<double>(samples.front().utime_us - t_from_us) * 1e-6
                             : 0.0;
  int64_t t = t_from_us;
  while (t < t_to_us) {
    const bool last = k + 1 >= samples.size();
    const int64_t until = last ? t_to_us : std::min(samples[k + 1].utime_us, t_to_us);
    if (until > t) {
      const auto [accel_0, gyro_0] = at(k, t);
      const auto [accel_1, gyro_1] = at(k, until);
      const double dt_s = static_cast<double>(until - t) * 1e-6;
      integrate(0.5 * (accel_0 + accel_1), 0.5 * (gyro_0 + gyro_1), dt_s);
      longest_gap_s = std::max(
          longest_gap_s,
          last ? dt_s : static_cast<double>(samples[k + 1].utime_us - samples[k].utime_us) * 1e-6);
      t = until;
    }
    if (last) {
      break;
    }
    ++k;
  }
  return longest_gap_s;
}

Eigen::Matrix3d ImuPreintegration::delta_R(const ImuBias& bias) const {
  return dR_ * so3::exp(dR_dbg_ * (bias.gyro_rps - bias_.gyro_rps));
}

Eigen::Vector3d ImuPreintegration::delta_v(const ImuBias& bias) const {
  return dv_ + dv_dba_ * (bias.accel_mps2 - bias_.accel_mps2) +
         dv_dbg_ * (bias.gyro_rps - bias_.gyro_rps);
}

Eigen::Vector3d ImuPreintegration::delta_p(const ImuBias& bias) const {
  return dp_ + dp_dba_ * (bias.accel_mps2 - bias_.accel_mps2) +
         dp_dbg_ * (bias.gyro_rps - bias_.gyro_rps);
}

double ImuPreintegration::accel_bias_variance_rate() const {
  return noise_.accel_bias_random_walk * noise_.accel_bias_random_walk;
}

double ImuPreintegration::gyro_bias_variance_rate() const {
  return noise_.gyro_bias_random_walk * noise_.gyro_bias_random_walk;
}

}  // namespace liloc
