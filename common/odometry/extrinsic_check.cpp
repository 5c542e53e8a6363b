#include "odometry/extrinsic_check.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

#include "math/se3.hpp"
#include "math/so3.hpp"
#include "math/trajectory.hpp"
#include "odometry/require_positive.hpp"

namespace liloc {
namespace {

// Pose pairs further apart than this (dropped sweeps) make poor rates and velocities.
constexpr double kMaxPairGapUs = 0.5e6;

// The index of the last sample at or before t_us (the first one for earlier times).
size_t sample_at(const std::vector<ImuSample>& imu, double t_us) {
  const auto it = std::upper_bound(imu.begin(), imu.end(), t_us, [](double t, const ImuSample& s) {
    return t < static_cast<double>(s.utime_us);
  });
  return static_cast<size_t>(std::max<std::ptrdiff_t>(it - imu.begin() - 1, 0));
}

// The gyro's integral over time, the samples held until the next one.
class GyroIntegral {
 public:
  explicit GyroIntegral(const std::vector<ImuSample>& imu) : imu_(imu) {
    prefix_.reserve(imu.size());
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (size_t i = 0; i < imu.size(); ++i) {
      prefix_.push_back(sum);
      if (i + 1 < imu.size()) {
        sum += imu[i].gyro_rps * ((imu[i + 1].utime_us - imu[i].utime_us) * 1e-6);
      }
    }
  }
  // The mean rate over [t0, t1] (IMU time, us, within the samples).
  Eigen::Vector3d mean(double t0_us, double t1_us) const {
    return (at(t1_us) - at(t0_us)) / ((t1_us - t0_us) * 1e-6);
  }

 private:
  // Integral from the first sample to t.
  Eigen::Vector3d at(double t_us) const {
    const size_t i = sample_at(imu_, t_us);
    return prefix_[i] + imu_[i].gyro_rps * ((t_us - imu_[i].utime_us) * 1e-6);
  }

  const std::vector<ImuSample>& imu_;
  std::vector<Eigen::Vector3d> prefix_;
};

// The gyro's rotation (bias removed) from the first sample on, samples held until the next.
class GyroRotation {
 public:
  GyroRotation(const std::vector<ImuSample>& imu, const Eigen::Vector3d& bias)
      : imu_(imu), bias_(bias) {
    prefix_.reserve(imu.size());
    Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
    for (size_t i = 0; i < imu.size(); ++i) {
      prefix_.push_back(R);
      if (i + 1 < imu.size()) {
        R = so3::normalize(R * so3::exp((imu[i].gyro_rps - bias) *
                                        ((imu[i + 1].utime_us - imu[i].utime_us) * 1e-6)));
      }
    }
  }
  // The rotation from t0 to t1 (IMU time, us, within the samples), in the body frame at t0.
  Eigen::Matrix3d between(double t0_us, double t1_us) const {
    return at(t0_us).transpose() * at(t1_us);
  }

 private:
  Eigen::Matrix3d at(double t_us) const {
    const size_t i = sample_at(imu_, t_us);
    return prefix_[i] * so3::exp((imu_[i].gyro_rps - bias_) * ((t_us - imu_[i].utime_us) * 1e-6));
  }
  const std::vector<ImuSample>& imu_;
  Eigen::Vector3d bias_;
  std::vector<Eigen::Matrix3d> prefix_;
};

// A rotation-rate pair: the LiDAR's over [t0, t1] (odometry time) in F.
struct RatePair {
  double t0_us, t1_us;
  Eigen::Vector3d omega_F;
};

// A velocity change over [t0, t1]: dv = g (t1 - t0) + M vec(R_BF^T), M summed over the
// IMU's specific force carried by the registered rotation.
struct VelocityPair {
  double t0_us, t1_us;
  Eigen::Vector3d dv;
  Eigen::Matrix<double, 3, 9> M;
};

using Params = Eigen::Matrix<double, 9, 1>;  // rotation increment, gravity, gyro bias

struct Fit {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d g = Eigen::Vector3d::Zero();
  Eigen::Vector3d bg = Eigen::Vector3d::Zero();
  double cost = std::numeric_limits<double>::infinity();
  Eigen::Matrix<double, 9, 9> covariance = Eigen::Matrix<double, 9, 9>::Identity();
  double gyro_rms = 0.0, velocity_rms = 0.0;
};

Eigen::Matrix<double, 9, 1> vec(const Eigen::Matrix3d& X) {
  return Eigen::Map<const Eigen::Matrix<double, 9, 1>>(X.data());
}

// The 24 rotations that map axes onto axes: the extrinsic mix-ups a user makes.
std::vector<Eigen::Matrix3d> axis_rotations() {
  std::vector<Eigen::Matrix3d> out;
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  for (int a = 0; a < 3; ++a) {
    for (int sa : {1, -1}) {
      for (int b = 0; b < 3; ++b) {
        if (b == a) {
          continue;
        }
        for (int sb : {1, -1}) {
          Eigen::Matrix3d R;
          R.col(0) = sa * I.col(a);
          R.col(1) = sb * I.col(b);
          R.col(2) = R.col(0).cross(R.col(1));
          out.push_back(R);
        }
      }
    }
  }
  return out;
}

// The minimum of costs sampled at first, first + step, ...: the best sample refined by the
// parabola through it and its neighbours.
double grid_minimum(const std::vector<double>& costs, double first, double step) {
  const size_t i =
      static_cast<size_t>(std::min_element(costs.begin(), costs.end()) - costs.begin());
  double best = first + static_cast<double>(i) * step;
  if (i > 0 && i + 1 < costs.size()) {
    const double curvature = costs[i - 1] - 2.0 * costs[i] + costs[i + 1];
    if (curvature > 0) {
      best += 0.5 * (costs[i - 1] - costs[i + 1]) / curvature * step;
    }
  }
  return best;
}

// A rotation the LiDAR registered over about interval_s (in the IMU's frame through the
// fitted rotation), and the squared change of the gyro's rate across it.
struct RotationInterval {
  double t0_us, t1_us;
  Eigen::Matrix3d dR_B;
  double share;
};

struct OffsetFound {
  double offset_us = 0.0;
  std::vector<double> parts_us;                                // found in each part of the motion
  double spread_us = std::numeric_limits<double>::infinity();  // the parts' about offset_us
};

// The clock offset on a grid over +-max_offset_s: the LiDAR's rotation over each interval
// against the gyro's over the same interval shifted by the offset. An offset dt moves the
// gyro's by dt times the change of the rate across the interval, which over a second of a
// turn's entry is ten times what it is across one pair of sweeps, while the registered
// rotation's error hardly grows (per pair of sweeps, the offset strayed up to 21 ms on
// correct rigs). The residual is also summed over offset_parts consecutive parts of the
// motion, each with an equal share of the rate changes: a clock offset shows in every
// part, a lag that follows where the sweeps saw structure (no residual-based sigma knows
// it) does not. Too few intervals (sweeps dropped): no offset, an infinite spread.
OffsetFound find_offset(const std::vector<RotationInterval>& intervals, const GyroRotation& gyro,
                        const ExtrinsicCheckConfig& config) {
  OffsetFound out;
  const size_t parts = static_cast<size_t>(config.offset_parts);
  if (intervals.size() < 5 * parts) {
    return out;
  }
  std::vector<size_t> part_of(intervals.size());
  double total_share = 0.0;
  for (const RotationInterval& r : intervals) {
    total_share += r.share;
  }
  double share_before = 0.0;
  for (size_t k = 0; k < intervals.size(); ++k) {
    part_of[k] = total_share > 0.0
                     ? std::min(parts - 1, static_cast<size_t>(parts * share_before / total_share))
                     : k * parts / intervals.size();
    share_before += intervals[k].share;
  }
  const double step_us = config.offset_step_s * 1e6;
  const int steps = static_cast<int>(std::round(config.max_offset_s / config.offset_step_s));
  // Costs at offsets (i - steps) * step_us: the whole window's, then each part's.
  std::vector<std::vector<double>> costs(parts + 1,
                                         std::vector<double>(static_cast<size_t>(2 * steps + 1)));
  for (int i = -steps; i <= steps; ++i) {
    const double offset_us = i * step_us;
    for (size_t k = 0; k < intervals.size(); ++k) {
      const RotationInterval& r = intervals[k];
      const Eigen::Matrix3d dR_I = gyro.between(r.t0_us - offset_us, r.t1_us - offset_us);
      const double cost = so3::log(r.dR_B.transpose() * dR_I).squaredNorm();
      costs[0][static_cast<size_t>(i + steps)] += cost;
      costs[1 + part_of[k]][static_cast<size_t>(i + steps)] += cost;
    }
  }
  const double first_us = static_cast<double>(-steps) * step_us;
  out.offset_us = grid_minimum(costs[0], first_us, step_us);
  double spread_sq = 0.0;
  for (size_t p = 1; p <= parts; ++p) {
    out.parts_us.push_back(grid_minimum(costs[p], first_us, step_us));
    spread_sq += std::pow(out.parts_us.back() - out.offset_us, 2);
  }
  out.spread_us = std::sqrt(spread_sq / static_cast<double>(parts - 1));
  return out;
}

class Problem {
 public:
  Problem(const std::vector<RatePair>& rates, const std::vector<Eigen::Vector3d>& omega_I,
          const std::vector<VelocityPair>& velocities, const ExtrinsicCheckConfig& config)
      : rates_(rates), omega_I_(omega_I), velocities_(velocities), config_(config) {}

  // Gauss-Newton with Huber weights (at 3 sigma) from R0.
  Fit solve(const Eigen::Matrix3d& R0) const {
    Fit fit;
    fit.R = R0;
    Eigen::Matrix<double, 9, 9> H;
    for (int iteration = 0; iteration < 20; ++iteration) {
      H.setZero();
      Params b = Params::Zero();
      accumulate(fit, H, b);
      const Params step = H.ldlt().solve(-b);
      if (!step.allFinite()) {
        break;
      }
      Eigen::Vector3d dphi = step.head<3>();
      if (dphi.norm() > 0.5) {
        dphi *= 0.5 / dphi.norm();
      }
      fit.R = so3::normalize(fit.R * so3::exp(dphi));
      fit.g += step.segment<3>(3);
      fit.bg += step.tail<3>();
      if (dphi.norm() < 1e-9) {
        break;
      }
    }
    H.setZero();
    Params b = Params::Zero();
    fit.cost = accumulate(fit, H, b);
    const int dof = std::max(1, 3 * static_cast<int>(rates_.size() + velocities_.size()) - 9);
    fit.covariance = H.inverse() * std::max(1.0, fit.cost / dof);
    double gyro_sq = 0.0, velocity_sq = 0.0;
    for (size_t k = 0; k < rates_.size(); ++k) {
      gyro_sq += gyro_residual(fit, k).squaredNorm();
    }
    for (const VelocityPair& v : velocities_) {
      velocity_sq += velocity_residual(fit.R, fit.g, v).squaredNorm();
    }
    fit.gyro_rms = std::sqrt(gyro_sq / std::max<size_t>(1, 3 * rates_.size()));
    fit.velocity_rms = std::sqrt(velocity_sq / std::max<size_t>(1, 3 * velocities_.size()));
    return fit;
  }

 private:
  Eigen::Vector3d gyro_residual(const Fit& fit, size_t k) const {
    return omega_I_[k] - fit.bg - fit.R * rates_[k].omega_F;
  }
  static Eigen::Vector3d velocity_residual(const Eigen::Matrix3d& R, const Eigen::Vector3d& g,
                                           const VelocityPair& v) {
    return v.dv - g * ((v.t1_us - v.t0_us) * 1e-6) - v.M * vec(R.transpose());
  }
  static double huber_weight(double normalized) {
    return normalized <= 3.0 ? 1.0 : 3.0 / normalized;
  }

  // Normal equations at `fit` (parameters: rotation increment on the right, gravity,
  // gyro bias); returns the robust cost.
  double accumulate(const Fit& fit, Eigen::Matrix<double, 9, 9>& H, Params& b) const {
    double cost = 0.0;
    const auto add = [&](const Eigen::Vector3d& r, const Eigen::Matrix<double, 3, 9>& J,
                         double sigma) {
      const double n = r.norm() / sigma;
      const double w = huber_weight(n) / (sigma * sigma);
      H += w * J.transpose() * J;
      b += w * J.transpose() * r;
      cost += n <= 3.0 ? n * n : 6.0 * n - 9.0;
    };
    for (size_t k = 0; k < rates_.size(); ++k) {
      Eigen::Matrix<double, 3, 9> J = Eigen::Matrix<double, 3, 9>::Zero();
      // d(-R Exp(phi) w)/dphi = R [w]x
      J.leftCols<3>() = fit.R * so3::hat(rates_[k].omega_F);
      J.rightCols<3>() = -Eigen::Matrix3d::Identity();
      add(gyro_residual(fit, k), J, config_.gyro_sigma_rps);
    }
    for (const VelocityPair& v : velocities_) {
      Eigen::Matrix<double, 3, 9> J = Eigen::Matrix<double, 3, 9>::Zero();
      const double h = 1e-6;
      for (int i = 0; i < 3; ++i) {
        const Eigen::Vector3d d = Eigen::Vector3d::Unit(i) * h;
        J.col(i) = (velocity_residual(fit.R * so3::exp(d), fit.g, v) -
                    velocity_residual(fit.R * so3::exp(-d), fit.g, v)) /
                   (2.0 * h);
      }
      J.middleCols<3>(3) = -Eigen::Matrix3d::Identity() * ((v.t1_us - v.t0_us) * 1e-6);
      add(velocity_residual(fit.R, fit.g, v), J, config_.velocity_sigma_mps);
    }
    return cost;
  }

  const std::vector<RatePair>& rates_;
  const std::vector<Eigen::Vector3d>& omega_I_;
  const std::vector<VelocityPair>& velocities_;
  const ExtrinsicCheckConfig& config_;
};

}  // namespace

void ExtrinsicCheckConfig::validate() const {
  require_positive({{"min_speed_mps", min_speed_mps},
                    {"min_turn_rps", min_turn_rps},
                    {"first_check_s", first_check_s},
                    {"check_every_s", check_every_s},
                    {"max_window_s", max_window_s},
                    {"interval_s", interval_s},
                    {"max_offset_s", max_offset_s},
                    {"offset_step_s", offset_step_s},
                    {"warn_rotation_deg", warn_rotation_deg},
                    {"warn_offset_s", warn_offset_s},
                    {"gyro_sigma_rps", gyro_sigma_rps},
                    {"velocity_sigma_mps", velocity_sigma_mps}},
                   "extrinsic_check.");
  if (!(max_window_s >= first_check_s) || !(offset_step_s < max_offset_s) || offset_parts < 2 ||
      offset_parts > 10) {
    throw std::invalid_argument(
        "extrinsic_check: need first_check_s <= max_window_s, offset_step_s < max_offset_s and "
        "offset_parts in [2, 10]");
  }
}

ExtrinsicCheck::ExtrinsicCheck(const ExtrinsicCheckConfig& config) : config_(config) {
  config_.validate();
}

void ExtrinsicCheck::add_imu(const ImuSample& sample) {
  if (done_ || (!imu_.empty() && sample.utime_us <= imu_.back().utime_us)) {
    return;
  }
  imu_.push_back(sample);
}

void ExtrinsicCheck::add_pose(int64_t utime_us, const Eigen::Isometry3d& T_local_body) {
  if (done_ || (!poses_.empty() && utime_us <= poses_.back().utime_us)) {
    return;
  }
  poses_.push_back({utime_us, T_local_body});
  if (motion_start_us_ < 0 && poses_.size() >= 2) {
    const Pose& a = poses_[poses_.size() - 2];
    const Pose& b = poses_.back();
    const double dt = (b.utime_us - a.utime_us) * 1e-6;
    const Eigen::Isometry3d delta = a.T.inverse() * b.T;
    if (delta.translation().norm() > config_.min_speed_mps * dt ||
        se3::rotation_angle(delta) > config_.min_turn_rps * dt) {
      motion_start_us_ = a.utime_us;
      next_check_us_ = motion_start_us_ + static_cast<int64_t>(config_.first_check_s * 1e6);
    }
  }
  if (motion_start_us_ < 0) {
    // Standing: keep only the last seconds, the start of the motion's window.
    const int64_t keep_from = utime_us - static_cast<int64_t>(2e6);
    const auto first_pose = std::find_if(poses_.begin(), poses_.end(),
                                         [&](const Pose& p) { return p.utime_us >= keep_from; });
    poses_.erase(poses_.begin(), first_pose);
    const auto first_imu = std::find_if(imu_.begin(), imu_.end(), [&](const ImuSample& s) {
      return s.utime_us >= keep_from - 1000000;
    });
    imu_.erase(imu_.begin(), first_imu);
  }
}

ExtrinsicEstimate ExtrinsicCheck::estimate() const {
  ExtrinsicEstimate out;
  if (poses_.size() < 3 || imu_.size() < 2) {
    return out;
  }
  const double max_offset_us = config_.max_offset_s * 1e6;
  const double imu_first = static_cast<double>(imu_.front().utime_us) + max_offset_us;
  const double imu_last = static_cast<double>(imu_.back().utime_us) - max_offset_us;
  const auto covered = [&](double t0, double t1) { return t0 >= imu_first && t1 <= imu_last; };

  std::vector<RatePair> rates;
  for (size_t k = 1; k < poses_.size(); ++k) {
    const double t0 = static_cast<double>(poses_[k - 1].utime_us);
    const double t1 = static_cast<double>(poses_[k].utime_us);
    if (t1 - t0 <= kMaxPairGapUs && covered(t0, t1)) {
      const Eigen::Matrix3d dR = poses_[k - 1].T.linear().transpose() * poses_[k].T.linear();
      rates.push_back({t0, t1, so3::log(dR) / ((t1 - t0) * 1e-6)});
    }
  }
  if (rates.size() < 10) {
    return out;
  }
  const GyroIntegral gyro(imu_);
  const auto omega_I = [&](double offset_us) {
    std::vector<Eigen::Vector3d> w;
    w.reserve(rates.size());
    for (const RatePair& r : rates) {
      w.push_back(gyro.mean(r.t0_us - offset_us, r.t1_us - offset_us));
    }
    return w;
  };

  // Registered velocities (central differences) at the sweeps' times.
  struct Velocity {
    double t_us;
    Eigen::Vector3d v;
  };
  std::vector<Velocity> velocities;
  for (size_t k = 1; k + 1 < poses_.size(); ++k) {
    const double t0 = static_cast<double>(poses_[k - 1].utime_us);
    const double t1 = static_cast<double>(poses_[k + 1].utime_us);
    if (t1 - t0 <= kMaxPairGapUs) {
      velocities.push_back(
          {0.5 * (t0 + t1),
           (poses_[k + 1].T.translation() - poses_[k - 1].T.translation()) / ((t1 - t0) * 1e-6)});
    }
  }
  std::vector<StampedPose> stamped;
  stamped.reserve(poses_.size());
  for (const Pose& p : poses_) {
    stamped.push_back({p.utime_us * 1e-6, p.T});
  }
  const Trajectory trajectory(std::move(stamped));
  // Every time asked lies within a velocity pair, so within the poses.
  const auto R_local_F = [&](double t_us) {
    return Eigen::Matrix3d(
        trajectory.at(t_us * 1e-6, std::numeric_limits<double>::infinity())->linear());
  };
  const auto velocity_pairs = [&](double offset_us) {
    std::vector<VelocityPair> out_pairs;
    size_t a = 0;
    for (size_t b = 1; b < velocities.size(); ++b) {
      if (velocities[b].t_us - velocities[a].t_us < config_.interval_s * 1e6) {
        continue;
      }
      VelocityPair pair{velocities[a].t_us, velocities[b].t_us, velocities[b].v - velocities[a].v,
                        Eigen::Matrix<double, 3, 9>::Zero()};
      const bool contiguous =
          velocities[b].t_us - velocities[a].t_us <= 2.0 * config_.interval_s * 1e6;
      a = b;
      if (!contiguous || !covered(pair.t0_us, pair.t1_us)) {
        continue;
      }
      // Specific force samples over the interval in IMU time, each held until the next.
      for (size_t i = sample_at(imu_, pair.t0_us - offset_us);
           i + 1 < imu_.size() && imu_[i].utime_us < pair.t1_us - offset_us; ++i) {
        const double s0 = std::max<double>(imu_[i].utime_us, pair.t0_us - offset_us);
        const double s1 = std::min<double>(imu_[i + 1].utime_us, pair.t1_us - offset_us);
        if (s1 <= s0) {
          continue;
        }
        const Eigen::Matrix3d R = R_local_F(0.5 * (s0 + s1) + offset_us);
        const Eigen::Vector3d& f = imu_[i].accel_mps2;
        const double dt = (s1 - s0) * 1e-6;
        for (int c = 0; c < 3; ++c) {
          pair.M.middleCols<3>(3 * c) += dt * f(c) * R;
        }
      }
      out_pairs.push_back(pair);
    }
    return out_pairs;
  };

  const auto best_fit = [&](double offset_us, const std::vector<Eigen::Matrix3d>& starts) {
    const std::vector<Eigen::Vector3d> w = omega_I(offset_us);
    const std::vector<VelocityPair> v = velocity_pairs(offset_us);
    const Problem problem(rates, w, v, config_);
    Fit best;
    for (const Eigen::Matrix3d& R0 : starts) {
      Fit fit = problem.solve(R0);
      if (fit.cost < best.cost) {
        best = fit;
      }
    }
    return best;
  };

  // The rotation first (a clock offset of tens of ms hardly moves it), then the offset
  // (find_offset), then the rotation again at the offset.
  Fit fit = best_fit(0.0, axis_rotations());
  const auto rate_near = [&](double t_us) { return gyro.mean(t_us - 10000.0, t_us + 10000.0); };
  std::vector<RotationInterval> intervals;
  for (size_t k = 0, j = 0; k < poses_.size(); ++k) {
    const double t0 = static_cast<double>(poses_[k].utime_us);
    j = std::max(j, k + 1);
    while (j < poses_.size() && poses_[j].utime_us - t0 < config_.interval_s * 1e6) {
      ++j;
    }
    if (j >= poses_.size()) {
      break;
    }
    const double t1 = static_cast<double>(poses_[j].utime_us);
    if (t1 - t0 > 2.0 * config_.interval_s * 1e6 || !covered(t0, t1)) {
      continue;
    }
    intervals.push_back(
        {t0, t1,
         fit.R * poses_[k].T.linear().transpose() * poses_[j].T.linear() * fit.R.transpose(),
         (rate_near(t1) - rate_near(t0)).squaredNorm()});
  }
  const OffsetFound offset = find_offset(intervals, GyroRotation(imu_, fit.bg), config_);
  for (const double part_us : offset.parts_us) {
    out.time_offset_parts_s.push_back(part_us * 1e-6);
  }
  out.time_offset_spread_s = offset.spread_us * 1e-6;
  fit = best_fit(offset.offset_us, {fit.R});
  const std::vector<Eigen::Vector3d> w_I = omega_I(offset.offset_us);
  double magnitude_sq = 0.0;
  for (size_t k = 0; k < rates.size(); ++k) {
    magnitude_sq += std::pow(rates[k].omega_F.norm() - (w_I[k] - fit.bg).norm(), 2);
  }
  out.rate_magnitude_rms_rps = std::sqrt(magnitude_sq / static_cast<double>(rates.size()));

  out.R_BF = fit.R;
  out.rotation_error_deg = so3::log(fit.R).norm() * so3::kRadToDeg;
  const Eigen::Matrix3d rotation_covariance = fit.covariance.topLeftCorner<3, 3>();
  out.rotation_sigma_deg =
      std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(rotation_covariance)
                                  .eigenvalues()
                                  .maxCoeff())) *
      so3::kRadToDeg;
  out.time_offset_error_s = offset.offset_us * 1e-6;
  out.gyro_bias_rps = fit.bg;
  out.gravity_mps2 = fit.g.norm();
  out.gyro_rms_rps = fit.gyro_rms;
  out.velocity_rms_mps = fit.velocity_rms;
  out.motion_s = motion_start_us_ < 0 ? 0.0 : (poses_.back().utime_us - motion_start_us_) * 1e-6;
  out.sweeps = static_cast<int>(rates.size());
  return out;
}

std::optional<ExtrinsicEstimate> ExtrinsicCheck::poll(
    const Eigen::Matrix3d& R_body_lidar_configured, double time_offset_configured_s) {
  if (done_ || motion_start_us_ < 0 || poses_.back().utime_us < next_check_us_) {
    return std::nullopt;
  }
  next_check_us_ += static_cast<int64_t>(config_.check_every_s * 1e6);
  ExtrinsicEstimate e = estimate();
  const bool window_full =
      poses_.back().utime_us - motion_start_us_ >= static_cast<int64_t>(config_.max_window_s * 1e6);
  // Rates that differ in size are the LiDAR registration's failure, not the mount's (VLP-16
  // campus C, a correct rig: the LiDAR-only poses turned 0.2-0.6 rad/s on a straight street,
  // "the motions fit poorly: check the extrinsic").
  const bool lidar_lost = e.rate_magnitude_rms_rps > 5.0 * config_.gyro_sigma_rps;
  const bool certain =
      e.sweeps > 0 && !lidar_lost && e.rotation_sigma_deg <= config_.warn_rotation_deg / 2.0;
  if (!certain && !window_full) {
    return std::nullopt;
  }
  done_ = true;
  imu_ = {};
  poses_ = {};
  const bool poor_fit = !lidar_lost && (e.gyro_rms_rps > 5.0 * config_.gyro_sigma_rps ||
                                        e.velocity_rms_mps > 5.0 * config_.velocity_sigma_mps);
  const bool rotation_off = certain && e.rotation_error_deg > config_.warn_rotation_deg &&
                            e.rotation_error_deg > 3.0 * e.rotation_sigma_deg;
  // The offset is fitted with the estimated rotation: without a certain rotation it is not
  // a finding (VLP-16 campus C, a correct rig: "72 ms"); nor is one that the parts of the
  // motion do not agree on (beyond twice their spread).
  const bool offset_off = certain && std::abs(e.time_offset_error_s) > config_.warn_offset_s &&
                          std::abs(e.time_offset_error_s) > 2.0 * e.time_offset_spread_s;
  e.warn = rotation_off || offset_off || poor_fit;
  const Eigen::Vector3d configured = so3::to_rpy(R_body_lidar_configured) * so3::kRadToDeg;
  const Eigen::Vector3d estimated = so3::to_rpy(e.R_BF * R_body_lidar_configured) * so3::kRadToDeg;
  std::string parts_ms;
  for (const double part_s : e.time_offset_parts_s) {
    parts_ms += (parts_ms.empty() ? "" : ", ") + std::to_string(std::lround(part_s * 1e3));
  }
  char offset_text[160] = "not checked (too few contiguous sweeps)";
  if (!parts_ms.empty()) {
    std::snprintf(offset_text, sizeof(offset_text), "%.1f ms (by part of the motion %s ms)",
                  1e3 * e.time_offset_error_s, parts_ms.c_str());
  }
  char text[640];
  if (lidar_lost) {
    std::snprintf(text, sizeof(text),
                  "extrinsic not checked: over %.0f s of motion the LiDAR-only registration's "
                  "rotation rates differ in size from the gyro's by %.3f rad/s rms, which no "
                  "mounting explains: the LiDAR alone did not follow the motion there (too "
                  "little structure?), so neither the rotation nor the clock offset is known",
                  e.motion_s, e.rate_magnitude_rms_rps);
  } else if (!certain) {
    std::snprintf(text, sizeof(text),
                  "extrinsic not checked: %.0f s of motion left the rotation uncertain (%.1f "
                  "+-%.1f deg, residuals %.3f rad/s %.3f m/s, gravity %.2f, %d sweeps), and the "
                  "clock offset with it%s",
                  e.motion_s, e.rotation_error_deg, e.rotation_sigma_deg, e.gyro_rms_rps,
                  e.velocity_rms_mps, e.gravity_mps2, e.sweeps,
                  poor_fit ? "; the motions fit poorly: check the extrinsic" : "");
  } else if (rotation_off) {
    // A wrong rotation distorts the LiDAR-only poses' timing too: the offset waits for it.
    std::snprintf(text, sizeof(text),
                  "the IMU and the LiDAR disagree over %.0f s of motion: the LiDAR looks mounted "
                  "at rpy (%.1f, %.1f, %.1f) deg, not the configured (%.1f, %.1f, %.1f) "
                  "(%.1f deg apart, +-%.1f); fix odometry.lidar_rpy_deg (the clock offset is "
                  "checked once the rotation is right)",
                  e.motion_s, estimated.x(), estimated.y(), estimated.z(), configured.x(),
                  configured.y(), configured.z(), e.rotation_error_deg, e.rotation_sigma_deg);
  } else if (e.warn) {
    std::snprintf(
        text, sizeof(text),
        "the IMU and the LiDAR disagree over %.0f s of motion: the LiDAR clock looks "
        "offset by %.3f s (by part of the motion %s ms), not the configured %.3f s "
        "(rotation within %.1f deg)%s; fix odometry.lidar_time_offset_s",
        e.motion_s, time_offset_configured_s + e.time_offset_error_s, parts_ms.c_str(),
        time_offset_configured_s, e.rotation_error_deg,
        poor_fit ? "; even so the motions fit poorly (the odometry may have diverged)" : "");
  } else {
    std::snprintf(text, sizeof(text),
                  "extrinsic checked over %.0f s of motion: rotation within %.1f deg (+-%.1f), "
                  "clock offset %s",
                  e.motion_s, e.rotation_error_deg, e.rotation_sigma_deg, offset_text);
  }
  e.message = text;
  return e;
}

}  // namespace liloc
