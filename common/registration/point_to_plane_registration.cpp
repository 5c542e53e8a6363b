#include "registration/point_to_plane_registration.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace liloc {
namespace {

constexpr int kNeighbors = 5;  // the plane through 5 neighbours, paper Eq. 6
// The neighbours must spread in their second direction by more than range noise does
// (m, 1 sigma).
constexpr double kMinSpread = 0.05;

// Normal equations accumulated over matched points, over the pose (N = 6) or the pose and
// a correction to the sweep's twist (N = 12).
template <int N>
struct Accumulator {
  Eigen::Matrix<double, N, N> H = Eigen::Matrix<double, N, N>::Zero();
  Eigen::Matrix<double, N, 1> g = Eigen::Matrix<double, N, 1>::Zero();
  double cost = 0.0;
  double squared_residuals = 0.0;
  int count = 0;

  void add(const Accumulator& o) {
    H += o.H;
    g += o.g;
    cost += o.cost;
    squared_residuals += o.squared_residuals;
    count += o.count;
  }
};

struct Match {
  Eigen::Vector3d point_source;  // as given, before a twist correction moves it
  double tau_s;                  // its time before the sweep's end (0 without times)
  Eigen::Vector3d normal;
  double offset;
  double weight;  // planarity ("roughness") weight of Eq. 6
};

// What the solver moves: the pose, and the correction to the twist the sweep was deskewed with
// (body frame at its end, [v; omega]).
struct Estimate {
  Eigen::Isometry3d T;
  Vector6d twist = Vector6d::Zero();
};

// The sweep's points and their times; without times only the pose is estimated.
struct TimedSource {
  const std::vector<Eigen::Vector3f>& points;
  const std::vector<double>& tau_s;  // empty, or one per point (s, at most 0)
};

// Point p, tau before the sweep's end, deskewed with a twist off by `twist`: to first order
// the body was at Exp(tau twist) relative to where the deskew put it.
Eigen::Vector3d moved(const Eigen::Vector3d& p, double tau_s, const Vector6d& twist) {
  return p + tau_s * (twist.head<3>() + twist.tail<3>().cross(p));
}

double cauchy_weight(double r, double scale) { return 1.0 / (1.0 + (r * r) / (scale * scale)); }

// Whether q, matched to `plane`, is a ceiling farther than far_ceiling_beyond_m from the
// sensor at sensor_target.
bool far_ceiling(const Plane& plane, const Eigen::Vector3d& q, const Eigen::Vector3d& sensor_target,
                 double far_ceiling_beyond_m) {
  constexpr double kMinLevelNormalZ = 0.5;  // within 60 degrees of level
  if (far_ceiling_beyond_m <= 0.0) {
    return false;
  }
  const Eigen::Vector3d from_sensor = q - sensor_target;
  return from_sensor.z() > 0.0 && std::abs(plane.normal.z()) >= kMinLevelNormalZ &&
         from_sensor.head<2>().norm() > far_ceiling_beyond_m;
}

// Whether the sensor at sensor_target sees the plane from the side opposite to the one its
// neighbours were seen from. A direction within kSideCos of the plane decides nothing: the
// normal of a fitted plane is off by degrees, and the ground seen at a grazing angle (views
// 5 degrees above it, planes of ring bands tilted by 8) would otherwise be judged seen from
// below. It stands where at least 3 neighbours decide and none disagrees, and where q lies
// at least min_offset_m off the plane.
template <int K>
bool seen_from_other_side(const Neighbors<K>& n, const Plane& plane, const Eigen::Vector3d& q,
                          const Eigen::Vector3d& sensor_target, double min_offset_m) {
  constexpr double kSideCos = 0.25;  // sin(14.5 deg)
  if (std::abs(plane.normal.dot(q) + plane.offset) < min_offset_m) {
    return false;
  }
  int front = 0;
  int back = 0;
  for (int k = 0; k < n.count; ++k) {
    const double side = plane.normal.dot(n.views[k].template cast<double>()) / 127.0;
    front += side > kSideCos;
    back += side < -kSideCos;
  }
  if (std::min(front, back) > 0 || std::max(front, back) < 3) {
    return false;
  }
  const double query_side = plane.normal.dot((sensor_target - q).normalized());
  return front > 0 ? query_side < -kSideCos : query_side > kSideCos;
}

double cauchy_cost(double r, double scale) {
  return 0.5 * scale * scale * std::log1p((r * r) / (scale * scale));
}

// Matches every source point, at the current estimate, to the plane of its neighbours.
std::vector<Match> associate(const TimedSource& source, const VoxelHashMap& map,
                             const Estimate& estimate, const RegistrationConfig& config,
                             const Eigen::Vector3d& sensor_origin_source) {
  const size_t count = source.points.size();
  const bool timed = !source.tau_s.empty();
  std::vector<Match> matches(count);
  std::vector<char> valid(count, 0);
  const Eigen::Isometry3d& T = estimate.T;
  const Eigen::Isometry3f Tf = T.cast<float>();
  const float radius = static_cast<float>(config.max_correspondence_m);
  const Eigen::Vector3d sensor_target = T * sensor_origin_source;
#pragma omp parallel for num_threads(config.threads) schedule(static)
  for (size_t i = 0; i < count; ++i) {
    const double tau_s = timed ? source.tau_s[i] : 0.0;
    const Eigen::Vector3f p =
        timed ? moved(source.points[i].cast<double>(), tau_s, estimate.twist).cast<float>()
              : source.points[i];
    const Eigen::Vector3f q = Tf * p;
    const Neighbors<kNeighbors> n = map.nearest<kNeighbors>(q, radius);
    if (n.count < kNeighbors) {
      continue;
    }
    const std::optional<Plane> plane =
        fit_plane(n.points.data(), n.count, config.max_plane_thickness_m, config.min_planarity);
    if (!plane) {
      continue;
    }
    const Eigen::Vector3d ray = (p.cast<double>() - sensor_origin_source).normalized();
    if (std::abs(plane->normal.dot(T.linear() * ray)) < config.min_incidence_cos ||
        far_ceiling(*plane, q.cast<double>(), sensor_target, config.far_ceiling_beyond_m) ||
        (config.reject_back_faces &&
         seen_from_other_side(n, *plane, q.cast<double>(), sensor_target,
                              config.back_face_min_offset_m))) {
      continue;
    }
    matches[i] = {source.points[i].cast<double>(), tau_s, plane->normal, plane->offset,
                  1.0 - plane->thickness_m / config.max_plane_thickness_m * 0.5};
    valid[i] = 1;
  }
  std::vector<Match> out;
  out.reserve(count);
  for (size_t i = 0; i < count; ++i) {
    if (valid[i]) {
      out.push_back(matches[i]);
    }
  }
  return out;
}

// Residuals, Jacobians and robust weights at the estimate; the Hessian and gradient of
// 0.5 * sum w rho(r) / sigma^2 over the right perturbation T Exp(xi) (and, N = 12, the twist
// correction).
template <int N>
Accumulator<N> linearize(const std::vector<Match>& matches, const Estimate& estimate,
                         const RegistrationConfig& config) {
  const Eigen::Matrix3d& R = estimate.T.linear();
  const Eigen::Vector3d& t = estimate.T.translation();
  const double info = 1.0 / (config.point_sigma_m * config.point_sigma_m);
  Accumulator<N> total;
#pragma omp parallel num_threads(config.threads)
  {
    Accumulator<N> local;
#pragma omp for schedule(static) nowait
    for (size_t i = 0; i < matches.size(); ++i) {
      const Match& m = matches[i];
      const Eigen::Vector3d q =
          N == 12 ? moved(m.point_source, m.tau_s, estimate.twist) : m.point_source;
      const double r = m.normal.dot(R * q + t) + m.offset;
      const Eigen::Vector3d n_source = R.transpose() * m.normal;
      Eigen::Matrix<double, N, 1> J;
      J.template head<3>() = n_source;               // d r / d rho = n^T R
      J.template segment<3>(3) = q.cross(n_source);  // d r / d phi = -n^T R [p]x
      if constexpr (N == 12) {                       // the twist's correction acts for tau
        J.template segment<3>(6) = m.tau_s * n_source;
        J.template tail<3>() = m.tau_s * m.point_source.cross(n_source);
      }
      const double w = m.weight * info * cauchy_weight(r, config.cauchy_scale_m);
      local.H.noalias() += w * J * J.transpose();
      local.g.noalias() += w * r * J;
      local.cost += m.weight * info * cauchy_cost(r, config.cauchy_scale_m);
      local.squared_residuals += r * r;
      ++local.count;
    }
#pragma omp critical
    total.add(local);
  }
  return total;
}

// Prior residuals at the estimate: the pose's e = T [-] T_prior, with its (approximately
// identity) Jacobian, and the twist correction's, zero-mean.
template <int N>
void add_priors(const std::optional<PosePrior>& prior, const Matrix6d& twist_information,
                const Estimate& estimate, Accumulator<N>& acc) {
  if (prior) {
    const Vector6d e = se3::minus(estimate.T, prior->T_target_source);
    acc.H.template topLeftCorner<6, 6>() += prior->information;
    acc.g.template head<6>() += prior->information * e;
    acc.cost += 0.5 * e.dot(prior->information * e);
  }
  if constexpr (N == 12) {
    acc.H.template bottomRightCorner<6, 6>() += twist_information;
    acc.g.template tail<6>() += twist_information * estimate.twist;
    acc.cost += 0.5 * estimate.twist.dot(twist_information * estimate.twist);
  }
}

template <int N>
Estimate plus(const Estimate& estimate, const Eigen::Matrix<double, N, 1>& step) {
  Estimate out{se3::plus(estimate.T, step.template head<6>()), estimate.twist};
  if constexpr (N == 12) {
    out.twist += step.template tail<6>();
  }
  return out;
}

double eigen_ratio(const Eigen::Matrix3d& block) {
  const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(block).eigenvalues();
  return ev.maxCoeff() > 0.0 ? ev.minCoeff() / ev.maxCoeff() : 0.0;
}
// The projector onto the eigenvectors of a 3x3 block with eigenvalue >= ratio * largest.
Eigen::Matrix3d constrained_block(const Eigen::Matrix3d& block, double ratio) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(block);
  const double largest = eigen.eigenvalues().maxCoeff();
  Eigen::Matrix3d projector = Eigen::Matrix3d::Zero();
  for (int k = 0; k < 3; ++k) {
    if (largest > 0.0 && eigen.eigenvalues()(k) >= ratio * largest) {
      projector += eigen.eigenvectors().col(k) * eigen.eigenvectors().col(k).transpose();
    }
  }
  return projector;
}
}  // namespace

Matrix6d RegistrationResult::independent_information(int independent) const {
  return information /
         std::max(1.0, static_cast<double>(correspondences) / static_cast<double>(independent));
}

Matrix6d constrained_directions(const Matrix6d& information, double degeneracy_ratio) {
  Matrix6d projector = Matrix6d::Zero();
  projector.topLeftCorner<3, 3>() =
      constrained_block(information.topLeftCorner<3, 3>(), degeneracy_ratio);
  projector.bottomRightCorner<3, 3>() =
      constrained_block(information.bottomRightCorner<3, 3>(), degeneracy_ratio);
  return projector;
}

void RegistrationConfig::validate() const {
  if (max_iterations < 1 || max_associations < 1 || threads < 1) {
    throw std::invalid_argument("max_iterations, max_associations and threads must be at least 1");
  }
  if (max_correspondence_m <= 0 || max_plane_thickness_m <= 0 || cauchy_scale_m <= 0 ||
      point_sigma_m <= 0) {
    throw std::invalid_argument("distances and sigmas must be positive");
  }
  if (!(min_planarity >= 0 && min_planarity <= 1)) {
    throw std::invalid_argument("min_planarity must lie in [0, 1]");
  }
  if (!(back_face_min_offset_m >= 0)) {
    throw std::invalid_argument("back_face_min_offset_m must be at least 0");
  }
  if (!(far_ceiling_beyond_m >= 0)) {
    throw std::invalid_argument("far_ceiling_beyond_m must be at least 0 (0: off)");
  }
}

void RegistrationStages::validate() const {
  if (voxel_m.empty() || correspondence_m.size() != voxel_m.size() ||
      plane_thickness_m.size() != voxel_m.size()) {
    throw std::invalid_argument(
        "registration stages: voxel_m, correspondence_m and plane_thickness_m need one value "
        "per stage, at least one");
  }
  for (size_t s = 0; s < voxel_m.size(); ++s) {
    if (!(voxel_m[s] > 0) || !(correspondence_m[s] > 0) || !(plane_thickness_m[s] > 0)) {
      throw std::invalid_argument("registration stages must be positive");
    }
  }
}

std::optional<Plane> fit_plane(const Eigen::Vector3f* points, int count, double max_thickness_m,
                               double min_planarity) {
  if (count < 3) {
    return std::nullopt;
  }
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int i = 0; i < count; ++i) {
    mean += points[i].cast<double>();
  }
  mean /= count;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d d = points[i].cast<double>() - mean;
    cov.noalias() += d * d.transpose();
  }
  cov /= count;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(cov);
  const Eigen::Vector3d normal = solver.eigenvectors().col(0).normalized();
  // The neighbours must span a patch, not a line: a sparse LiDAR samples the ground in
  // rings, and five points along one ring, spread across it only by range noise, fit a
  // "plane" that contains the ray. Such planes pin the sensor to its own rings and
  // make the registration stick to zero motion.
  if (solver.eigenvalues()(1) < min_planarity * solver.eigenvalues()(2) ||
      solver.eigenvalues()(1) < kMinSpread * kMinSpread) {
    return std::nullopt;
  }
  double thickness = 0.0;
  for (int i = 0; i < count; ++i) {
    thickness = std::max(thickness, std::abs(normal.dot(points[i].cast<double>() - mean)));
  }
  if (thickness > max_thickness_m) {
    return std::nullopt;
  }
  return Plane{normal, -normal.dot(mean), thickness};
}

namespace {

// Levenberg-Marquardt from the guess, re-associating between the first iterations. Fills
// `result` from the last correspondences and returns the estimate with the information of
// the residuals alone.
template <int N>
std::pair<Estimate, Eigen::Matrix<double, N, N>> solve(
    const TimedSource& source, const VoxelHashMap& target, Estimate estimate,
    const std::optional<PosePrior>& prior, const Matrix6d& twist_information,
    const RegistrationConfig& config, const Eigen::Vector3d& sensor_origin_source,
    RegistrationResult& result) {
  using VectorN = Eigen::Matrix<double, N, 1>;
  using MatrixN = Eigen::Matrix<double, N, N>;
  double lambda = 1e-6;  // Levenberg-Marquardt damping, relative to the diagonal
  // A twist correction's step is small when it moves the sweep's earliest point by less than
  // the pose's thresholds.
  double longest_tau_s = 0.0;
  for (const double tau_s : source.tau_s) {
    longest_tau_s = std::max(longest_tau_s, std::abs(tau_s));
  }
  const auto small = [&](const VectorN& step) {
    bool below = step.template head<3>().norm() < config.convergence_translation_m &&
                 step.template segment<3>(3).norm() < config.convergence_rotation_rad;
    if constexpr (N == 12) {
      below =
          below &&
          step.template segment<3>(6).norm() * longest_tau_s < config.convergence_translation_m &&
          step.template tail<3>().norm() * longest_tau_s < config.convergence_rotation_rad;
    }
    return below;
  };
  std::vector<Match> matches;
  for (int iteration = 0; iteration < config.max_iterations; ++iteration) {
    result.iterations = iteration + 1;
    // Re-associate while the estimate still moves much; later steps refine with the same
    // planes, which costs a fraction of a search.
    if (iteration < config.max_associations) {
      matches = associate(source, target, estimate, config, sensor_origin_source);
    }
    Accumulator<N> acc = linearize<N>(matches, estimate, config);
    add_priors(prior, twist_information, estimate, acc);
    if (acc.count < N && !prior) {
      break;  // nothing to register against
    }
    // LM: accept the step if it lowers the cost with these correspondences, else damp.
    VectorN step = VectorN::Zero();
    bool accepted = false;
    for (int attempt = 0; attempt < 8 && !accepted; ++attempt) {
      MatrixN A = acc.H;
      A.diagonal() += lambda * acc.H.diagonal().cwiseMax(1e-9);
      step = -A.ldlt().solve(acc.g);
      const Estimate candidate = plus<N>(estimate, step);
      Accumulator<N> next = linearize<N>(matches, candidate, config);
      add_priors(prior, twist_information, candidate, next);
      if (next.cost <= acc.cost) {
        estimate = candidate;
        lambda = std::max(lambda * 0.1, 1e-9);
        accepted = true;
      } else {
        lambda *= 10.0;
      }
    }
    if (!accepted) {
      // Stalled: converged only if even the undamped step is below the thresholds (the
      // cost cannot fall further at machine precision), not when the steps are refused.
      const VectorN undamped = -acc.H.ldlt().solve(acc.g);
      result.converged = undamped.allFinite() && small(undamped);
      break;
    }
    if (small(step)) {
      result.converged = true;
      break;
    }
  }
  // The information at the solution, from the last correspondences (a final search
  // would cost as much as an iteration and changes nothing once converged).
  const Accumulator<N> final_acc = linearize<N>(matches, estimate, config);
  const Matrix6d pose_information = final_acc.H.template topLeftCorner<6, 6>();
  result.T_target_source = estimate.T;
  result.information = pose_information;
  result.correspondences = final_acc.count;
  result.rms_residual_m =
      final_acc.count > 0 ? std::sqrt(final_acc.squared_residuals / final_acc.count) : 0.0;
  result.translation_eigen_ratio = eigen_ratio(pose_information.topLeftCorner<3, 3>());
  result.rotation_eigen_ratio = eigen_ratio(pose_information.bottomRightCorner<3, 3>());
  result.degenerate = result.translation_eigen_ratio < config.degeneracy_ratio ||
                      result.rotation_eigen_ratio < config.degeneracy_ratio;
  return {estimate, final_acc.H};
}

}  // namespace

RegistrationResult register_point_to_plane(const std::vector<Eigen::Vector3f>& source,
                                           const VoxelHashMap& target,
                                           const Eigen::Isometry3d& T_target_source_guess,
                                           const std::optional<PosePrior>& prior,
                                           const RegistrationConfig& config,
                                           const Eigen::Vector3d& sensor_origin_source) {
  static const std::vector<double> kUntimed;
  RegistrationResult result;
  solve<6>(TimedSource{source, kUntimed}, target, Estimate{T_target_source_guess}, prior,
           Matrix6d::Zero(), config, sensor_origin_source, result);
  return result;
}

TwistRegistrationResult register_point_to_plane_with_twist(
    const std::vector<Eigen::Vector3f>& source, const std::vector<double>& tau_s,
    const VoxelHashMap& target, const Eigen::Isometry3d& T_target_source_guess,
    const std::optional<PosePrior>& prior, const Matrix6d& twist_information,
    const RegistrationConfig& config, const Eigen::Vector3d& sensor_origin_source) {
  if (tau_s.size() != source.size()) {
    throw std::invalid_argument(
        "register_point_to_plane_with_twist: " + std::to_string(tau_s.size()) + " times for " +
        std::to_string(source.size()) + " points");
  }
  TwistRegistrationResult out;
  const auto [estimate, information] =
      solve<12>(TimedSource{source, tau_s}, target, Estimate{T_target_source_guess}, prior,
                twist_information, config, sensor_origin_source, out.pose);
  out.twist_correction = estimate.twist;
  out.twist_information = information.bottomRightCorner<6, 6>();
  return out;
}

}  // namespace liloc
