#include "odometry/imu_propagation.hpp"

#include <algorithm>
#include <stdexcept>

#include "math/so3.hpp"

namespace liloc {

void ImuNoiseConfig::validate() const {
  ImuNoiseDensities::validate();
  if (!(max_sample_gap_s > 0) || !(gap_accel_density >= 0) || !(gap_gyro_density >= 0) ||
      !(gravity_direction_random_walk >= 0)) {
    throw std::invalid_argument(
        "max_sample_gap_s must be positive, the gap densities and the gravity direction's "
        "random walk non-negative");
  }
}

PropagationStats propagate(NavState& x, StateMatrix& P, int64_t t_from, int64_t t_to,
                           const std::vector<ImuSample>& samples, const ImuNoiseConfig& noise,
                           MotionProfile* motion) {
  PropagationStats stats;
  if (samples.empty()) {
    throw std::invalid_argument("propagation needs at least one IMU sample");
  }
  size_t k = 0;
  int64_t t = t_from;
  Eigen::Vector3d omega = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_local = x.g;
  while (t < t_to) {
    while (k + 1 < samples.size() && samples[k + 1].utime_us <= t) {
      ++k;
    }
    const bool has_next = k + 1 < samples.size();
    const int64_t t_next = has_next ? std::min(t_to, samples[k + 1].utime_us) : t_to;
    const double dt = (t_next - t) * 1e-6;
    // Mid-point of the two samples around the step (the held sample beyond the last).
    const ImuSample& a = samples[k];
    const ImuSample& b = has_next ? samples[k + 1] : samples[k];
    const double spacing_s = has_next ? (b.utime_us - a.utime_us) * 1e-6 : 0.0;
    bool unmeasured = false;
    if (spacing_s > noise.max_sample_gap_s) {
      ++stats.gaps;
      unmeasured = true;
    }
    if (!has_next) {
      // Past the last sample the IMU is a guess, once the silence is longer than usual.
      stats.extrapolated_s += dt;
      unmeasured = unmeasured || (t_next - a.utime_us) * 1e-6 > noise.max_sample_gap_s;
    }
    omega = 0.5 * (a.gyro_rps + b.gyro_rps) - x.bg;
    const Eigen::Vector3d acc = 0.5 * (a.accel_mps2 + b.accel_mps2) - x.ba;
    accel_local = x.R * acc + x.g;
    if (motion != nullptr) {
      motion->add({t, x.R, x.p, x.v, omega, accel_local});
    }
    // Error-state transition F and process noise Q over dt. The position error rho is
    // in the body frame: it turns with the body (E = Exp(-omega dt)) and takes the world-
    // frame position error of the step through R^T.
    const Eigen::Matrix3d R = x.R;
    const Eigen::Matrix3d E = so3::exp(-omega * dt);
    const Eigen::Matrix3d acc_hat = so3::hat(acc);
    const Eigen::Matrix<double, 3, 2> G = gravity_jacobian(x.g);
    StateMatrix F = StateMatrix::Identity();
    F.block<3, 3>(kPos, kPos) = E;
    F.block<3, 3>(kPos, kRot) = -0.5 * E * acc_hat * dt * dt;
    F.block<3, 3>(kPos, kVel) = E * R.transpose() * dt;
    F.block<3, 3>(kPos, kBa) = -0.5 * E * dt * dt;
    F.block<3, 2>(kPos, kGrav) = 0.5 * E * R.transpose() * G * dt * dt;
    F.block<3, 3>(kRot, kRot) = E;
    F.block<3, 3>(kRot, kBg) = -so3::right_jacobian(omega * dt) * dt;
    F.block<3, 3>(kVel, kRot) = -R * acc_hat * dt;
    F.block<3, 3>(kVel, kBa) = -R * dt;
    F.block<3, 2>(kVel, kGrav) = G * dt;
    StateVector q = StateVector::Zero();
    q.segment<3>(kRot).setConstant(noise.gyro_noise_density * noise.gyro_noise_density * dt);
    q.segment<3>(kVel).setConstant(noise.accel_noise_density * noise.accel_noise_density * dt);
    q.segment<3>(kBg).setConstant(noise.gyro_bias_random_walk * noise.gyro_bias_random_walk * dt);
    q.segment<3>(kBa).setConstant(noise.accel_bias_random_walk * noise.accel_bias_random_walk * dt);
    q.segment<2>(kGrav).setConstant(noise.gravity_direction_random_walk *
                                    noise.gravity_direction_random_walk * dt);
    if (unmeasured) {
      q.segment<3>(kRot).array() += noise.gap_gyro_density * noise.gap_gyro_density * dt;
      q.segment<3>(kVel).array() += noise.gap_accel_density * noise.gap_accel_density * dt;
    }
    P = F * P * F.transpose();
    P.diagonal() += q;

    x.p += x.v * dt + 0.5 * accel_local * dt * dt;
    x.v += accel_local * dt;
    x.R = so3::normalize(x.R * so3::exp(omega * dt));
    t = t_next;
  }
  if (motion != nullptr) {
    motion->add({t_to, x.R, x.p, x.v, omega, accel_local});
  }
  P = 0.5 * (P + P.transpose());
  return stats;
}

}  // namespace liloc
