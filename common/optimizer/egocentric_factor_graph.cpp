#include "optimizer/egocentric_factor_graph.hpp"

#include <ceres/covariance.h>
#include <ceres/normal_prior.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "factors/imu_factor.hpp"
#include "factors/pose_prior_factor.hpp"
#include "factors/relative_pose_factor.hpp"
#include "math/stopwatch.hpp"

namespace liloc {
namespace {

Matrix6d sqrt_information(double sigma_m, double sigma_rad) {
  Vector6d d;
  d << Eigen::Vector3d::Constant(1.0 / sigma_m), Eigen::Vector3d::Constant(1.0 / sigma_rad);
  return d.asDiagonal();
}

// A scan-match edge's square-root information: the base sigmas, but per block (translation,
// rotation) in no eigen-direction more than the registration's information holds, shared
// among the `edges` edges that one registration becomes.
Matrix6d scan_match_sqrt_information(double sigma_m, double sigma_rad,
                                     const std::optional<Matrix6d>& measured, size_t edges) {
  if (!measured) {
    return sqrt_information(sigma_m, sigma_rad);
  }
  Matrix6d root = Matrix6d::Zero();
  for (const int block : {0, 3}) {
    const double base = 1.0 / std::pow(block == 0 ? sigma_m : sigma_rad, 2);
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(measured->block<3, 3>(block, block) /
                                                               static_cast<double>(edges));
    const Eigen::Vector3d root_values =
        eigen.eigenvalues().cwiseMax(0.0).cwiseMin(base).cwiseSqrt();
    root.block<3, 3>(block, block) =
        eigen.eigenvectors() * root_values.asDiagonal() * eigen.eigenvectors().transpose();
  }
  return root;
}

// Eq. 7's noise: the odometry's covariances of both keyframes carried onto their relative
// pose (their correlation, positive through the odometry's shared local map, left out,
// which overstates the noise), and the sigmas added: the drift that a filter's covariance
// against its own local map does not hold.
Matrix6d odometry_sqrt_information(const Eigen::Isometry3d& T_ab, const Matrix6d& covariance_a,
                                   const Matrix6d& covariance_b, double sigma_m, double sigma_rad) {
  Vector6d variance;
  variance << Eigen::Vector3d::Constant(sigma_m * sigma_m),
      Eigen::Vector3d::Constant(sigma_rad * sigma_rad);
  const Matrix6d covariance =
      relative_pose_covariance(T_ab, covariance_a, covariance_b) + Matrix6d(variance.asDiagonal());
  // U with U^T U = covariance^-1.
  return Matrix6d(covariance.inverse().llt().matrixU());
}

}  // namespace

void EgocentricGraphConfig::validate() const {
  if (window_rlm < 2 || window_ilm < 2 || prior_nodes < 1) {
    throw std::invalid_argument("the windows need at least 2 keyframes, prior_nodes at least 1");
  }
  if (!(scan_match_sigma_m > 0) || !(scan_match_sigma_rad > 0) || !(fitness_reference_m > 0) ||
      !(scan_match_loss_scale > 0) || !(prior_node_sigma_m > 0) || !(prior_node_sigma_rad > 0) ||
      !(odometry_sigma_m > 0) || !(odometry_sigma_rad > 0) || !(odometry_sigma_per_m >= 0) ||
      !(odometry_floor_sigma_m > 0) || !(odometry_floor_sigma_rad > 0) ||
      !(odometry_floor_sigma_per_m >= 0) || !(odometry_loss_scale >= 0) || !(max_imu_span_s > 0) ||
      !(max_imu_gap_s > 0) || !(initial_accel_bias_sigma_mps2 > 0) ||
      !(initial_gyro_bias_sigma_rps > 0) || !(map_tilt_sigma_rad > 0) || max_iterations < 1) {
    throw std::invalid_argument(
        "the optimizer's sigmas, fitness_reference_m, scan_match_loss_scale and the IMU spans "
        "must be positive, odometry_loss_scale not negative, max_iterations at least 1");
  }
  imu.validate();
}

EgocentricFactorGraph::EgocentricFactorGraph(const EgocentricGraphConfig& config)
    : config_(config) {
  config_.validate();
}

void EgocentricFactorGraph::add_factor(ceres::CostFunction* cost,
                                       std::shared_ptr<ceres::LossFunction> loss,
                                       std::vector<StateBlock> blocks) {
  factors_.push_back(
      {std::shared_ptr<ceres::CostFunction>(cost), std::move(loss), std::move(blocks)});
}

void EgocentricFactorGraph::start(const GraphKeyframe& keyframe,
                                  const Eigen::Isometry3d& T_map_body, const Matrix6d& covariance) {
  nodes_.clear();
  priors_.clear();
  factors_.clear();
  auto node = std::make_unique<Node>();
  node->id = keyframe.id;
  node->utime_us = keyframe.utime_us;
  node->T_odom_body = keyframe.T_odom_body;
  node->odometry_covariance = keyframe.odometry_covariance;
  node->pose = pose_block(T_map_body);
  // The robot's anchor Q^b: the initial pose with its covariance.
  const Matrix6d information = covariance.inverse();
  add_factor(PosePriorFactor::create(T_map_body, information.llt().matrixU()), nullptr,
             {{node->pose.data(), 7, true}});
  if (config_.use_imu) {
    map_tilt_ = {0.0, 0.0};
    add_factor(new ceres::NormalPrior(Eigen::Matrix2d::Identity() / config_.map_tilt_sigma_rad,
                                      Eigen::VectorXd::Zero(2)),
               nullptr, {{map_tilt_.data(), 2, false}});
  }
  nodes_.push_back(std::move(node));
}

void EgocentricFactorGraph::add_bias_prior(Node& node) {
  Eigen::Matrix<double, 6, 1> inverse_sigma;
  inverse_sigma << Eigen::Vector3d::Constant(1.0 / config_.initial_accel_bias_sigma_mps2),
      Eigen::Vector3d::Constant(1.0 / config_.initial_gyro_bias_sigma_rps);
  add_factor(new ceres::NormalPrior(inverse_sigma.asDiagonal().toDenseMatrix(),
                                    Eigen::Map<const Eigen::VectorXd>(node.bias.data(), 6)),
             nullptr, {{node.bias.data(), 6, false}});
  node.bias_held = true;
}

bool EgocentricFactorGraph::add_imu(Node& from, Node& to, const std::vector<ImuSample>& imu) {
  const double span_s = static_cast<double>(to.utime_us - from.utime_us) * 1e-6;
  if (!config_.use_imu || imu.empty() || span_s > config_.max_imu_span_s ||
      imu.front().utime_us > from.utime_us + static_cast<int64_t>(config_.max_imu_gap_s * 1e6) ||
      imu.back().utime_us < to.utime_us - static_cast<int64_t>(config_.max_imu_gap_s * 1e6)) {
    return false;
  }
  ImuBias bias;
  bias.accel_mps2 = Eigen::Vector3d(from.bias[0], from.bias[1], from.bias[2]);
  bias.gyro_rps = Eigen::Vector3d(from.bias[3], from.bias[4], from.bias[5]);
  ImuPreintegration preintegration(bias, config_.imu);
  if (preintegration.integrate(imu, from.utime_us, to.utime_us) > config_.max_imu_gap_s) {
    return false;
  }
  if (!from.bias_held) {
    add_bias_prior(from);
  }
  to.bias_held = true;
  add_factor(ImuFactor::create(preintegration, config_.imu.gravity_mps2), nullptr,
             {{from.pose.data(), 7, true},
              {from.velocity.data(), 3, false},
              {from.bias.data(), 6, false},
              {to.pose.data(), 7, true},
              {to.velocity.data(), 3, false},
              {to.bias.data(), 6, false},
              {map_tilt_.data(), 2, false}});
  return true;
}

int EgocentricFactorGraph::add_scan_match(Node& node, const ScanMatch& match) {
  const auto loss = std::make_shared<ceres::CauchyLoss>(config_.scan_match_loss_scale);
  const StateBlock current{node.pose.data(), 7, true};
  if (config_.direct || match.prior_nodes.empty()) {
    add_factor(PosePriorFactor::create(
                   match.T_map_body,
                   scan_match_sqrt_information(config_.scan_match_sigma_m,
                                               config_.scan_match_sigma_rad, match.information, 1)),
               loss, {current});
    return 1;
  }
  // Eq. 8, the propagation model: edges T_i^-1 T_r from the N_d nearest prior nodes, each
  // with the base noise scaled by the fitness against prior keyframe i.
  const size_t edges = std::min(match.prior_nodes.size(), static_cast<size_t>(config_.prior_nodes));
  int added = 0;
  for (const PriorNodeMatch& p : match.prior_nodes) {
    if (added >= config_.prior_nodes) {
      break;
    }
    std::unique_ptr<Prior>& prior = priors_[p.map_keyframe_id];
    if (!prior) {
      prior = std::make_unique<Prior>();
      prior->pose = pose_block(p.T_map_keyframe);
      add_factor(
          PosePriorFactor::create(p.T_map_keyframe, sqrt_information(config_.prior_node_sigma_m,
                                                                     config_.prior_node_sigma_rad)),
          nullptr, {prior->block()});
    }
    const double scale =
        config_.unweighted ? 1.0 : std::max(1.0, p.fitness_m / config_.fitness_reference_m);
    add_factor(
        RelativePoseFactor::create(p.T_map_keyframe.inverse() * match.T_map_body,
                                   scan_match_sqrt_information(scale * config_.scan_match_sigma_m,
                                                               scale * config_.scan_match_sigma_rad,
                                                               match.information, edges)),
        loss, {prior->block(), current});
    ++added;
  }
  return added;
}

GraphEstimate EgocentricFactorGraph::add(const GraphKeyframe& keyframe) {
  if (nodes_.empty()) {
    throw std::logic_error("EgocentricFactorGraph::add before start");
  }
  Node& previous = *nodes_.back();
  if (keyframe.utime_us <= previous.utime_us) {
    throw std::invalid_argument("keyframe " + std::to_string(keyframe.id) +
                                " is not after the previous one");
  }
  auto node = std::make_unique<Node>();
  node->id = keyframe.id;
  node->utime_us = keyframe.utime_us;
  node->T_odom_body = keyframe.T_odom_body;
  node->odometry_covariance = keyframe.odometry_covariance;
  // Eq. 7: the odometry's relative pose, and the initial value it predicts.
  const Eigen::Isometry3d T_prev_cur = previous.T_odom_body.inverse() * keyframe.T_odom_body;
  const Eigen::Isometry3d T_map_prev = pose_of(previous.pose.data());
  node->pose = pose_block(T_map_prev * T_prev_cur);
  const double dt_s = static_cast<double>(keyframe.utime_us - previous.utime_us) * 1e-6;
  const Eigen::Vector3d velocity =
      (T_map_prev * T_prev_cur).translation() - T_map_prev.translation();
  for (int k = 0; k < 3; ++k) {
    node->velocity[static_cast<size_t>(k)] = velocity(k) / dt_s;
  }
  node->bias = previous.bias;
  GraphEstimate estimate;
  estimate.imu_factor = add_imu(previous, *node, keyframe.imu);
  const double step_m = T_prev_cur.translation().norm();
  const double sigma_m = config_.odometry_sigma_m + config_.odometry_sigma_per_m * step_m;
  Matrix6d odometry_information = sqrt_information(sigma_m, config_.odometry_sigma_rad);
  if (config_.odometry_covariance && previous.odometry_covariance && node->odometry_covariance) {
    // The floor is small where an IMU factor spans the step (EgocentricGraphConfig).
    const bool imu = estimate.imu_factor;
    odometry_information = odometry_sqrt_information(
        T_prev_cur, *previous.odometry_covariance, *node->odometry_covariance,
        imu ? config_.odometry_floor_sigma_m + config_.odometry_floor_sigma_per_m * step_m
            : sigma_m,
        imu ? config_.odometry_floor_sigma_rad : config_.odometry_sigma_rad);
  }
  add_factor(RelativePoseFactor::create(T_prev_cur, odometry_information),
             config_.odometry_loss_scale > 0
                 ? std::make_shared<ceres::CauchyLoss>(config_.odometry_loss_scale)
                 : nullptr,
             {{previous.pose.data(), 7, true}, {node->pose.data(), 7, true}});
  Node& current = *node;
  nodes_.push_back(std::move(node));
  if (keyframe.scan_match && mode_ == LocalizationMode::kRelocalization) {
    estimate.scan_match_factors = add_scan_match(current, *keyframe.scan_match);
  }
  const Stopwatch solve_watch;
  estimate.final_cost = solve(current, estimate);
  estimate.solve_ms = solve_watch.ms() - estimate.covariance_ms;
  estimate.keyframe_id = current.id;
  estimate.utime_us = current.utime_us;
  estimate.T_map_body = pose_of(current.pose.data());
  estimate.velocity_map =
      Eigen::Vector3d(current.velocity[0], current.velocity[1], current.velocity[2]);
  estimate.bias.accel_mps2 = Eigen::Vector3d(current.bias[0], current.bias[1], current.bias[2]);
  estimate.bias.gyro_rps = Eigen::Vector3d(current.bias[3], current.bias[4], current.bias[5]);
  const Stopwatch marginalization_watch;
  marginalize_old(estimate);
  estimate.marginalization_ms = marginalization_watch.ms();
  estimate.window = static_cast<int>(nodes_.size());
  estimate.prior_node_count = static_cast<int>(priors_.size());
  return estimate;
}

double EgocentricFactorGraph::solve(Node& newest, GraphEstimate& estimate) {
  ceres::Problem::Options options;
  options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(options);
  for (const FactorRecord& f : factors_) {
    std::vector<double*> blocks;
    for (const StateBlock& b : f.blocks) {
      blocks.push_back(b.data);
    }
    problem.AddResidualBlock(f.cost.get(), f.loss.get(), blocks);
    for (const StateBlock& b : f.blocks) {
      if (b.pose) {
        problem.SetManifold(b.data, se3_.get());
      }
    }
  }
  ceres::Solver::Options solver;
  // A window is small and dense; a graph that grows (no_marginalization) is sparse.
  solver.linear_solver_type = nodes_.size() <= 2 * static_cast<size_t>(config_.window_ilm)
                                  ? ceres::DENSE_SCHUR
                                  : ceres::SPARSE_NORMAL_CHOLESKY;
  solver.max_num_iterations = config_.max_iterations;
  solver.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  if (config_.compute_covariance) {
    // The newest pose's marginal covariance in the window, in the manifold's tangent space
    // (right perturbation, translation then rotation).
    const Stopwatch watch;
    ceres::Covariance::Options options_cov;
    options_cov.num_threads = 1;
    ceres::Covariance covariance(options_cov);
    double* pose = newest.pose.data();
    Eigen::Matrix<double, 6, 6, Eigen::RowMajor> c;
    const std::vector<std::pair<const double*, const double*>> blocks{{pose, pose}};
    estimate.covariance_ok = covariance.Compute(blocks, &problem) &&
                             covariance.GetCovarianceBlockInTangentSpace(pose, pose, c.data()) &&
                             c.allFinite();
    if (estimate.covariance_ok) {
      estimate.covariance = c;
    }
    estimate.covariance_ms = watch.ms();
  }
  return summary.final_cost;
}

void EgocentricFactorGraph::marginalize_old(GraphEstimate& estimate) {
  const size_t window = static_cast<size_t>(
      mode_ == LocalizationMode::kRelocalization ? config_.window_rlm : config_.window_ilm);
  if (config_.no_marginalization) {
    return;
  }
  while (nodes_.size() > window) {
    std::vector<const double*> dropped;
    Node& oldest = *nodes_.front();
    dropped.push_back(oldest.pose.data());
    dropped.push_back(oldest.velocity.data());
    dropped.push_back(oldest.bias.data());
    // Prior nodes that only the dropped keyframe's factors (and their own anchors) use.
    std::vector<int64_t> dropped_priors;
    for (const auto& [id, prior] : priors_) {
      const double* block = prior->pose.data();
      const bool needed = std::any_of(factors_.begin(), factors_.end(), [&](const FactorRecord& f) {
        const bool touches_prior = std::any_of(
            f.blocks.begin(), f.blocks.end(), [&](const StateBlock& b) { return b.data == block; });
        const bool touches_dropped =
            std::any_of(f.blocks.begin(), f.blocks.end(), [&](const StateBlock& b) {
              return std::find(dropped.begin(), dropped.end(), b.data) != dropped.end();
            });
        return touches_prior && !touches_dropped && f.blocks.size() > 1;
      });
      if (!needed) {
        dropped.push_back(block);
        dropped_priors.push_back(id);
      }
    }
    // Eqs. 9-10: marginalization; the factors touching the dropped states become one prior.
    const std::shared_ptr<MarginalPrior> prior = marginalize(factors_, dropped);
    std::vector<FactorRecord> kept;
    for (FactorRecord& f : factors_) {
      const bool drops = std::any_of(f.blocks.begin(), f.blocks.end(), [&](const StateBlock& b) {
        return std::find(dropped.begin(), dropped.end(), b.data) != dropped.end();
      });
      if (!drops) {
        kept.push_back(std::move(f));
      }
    }
    if (prior) {
      kept.push_back(prior->factor());
    }
    factors_ = std::move(kept);
    estimate.finalized.push_back({oldest.id, oldest.utime_us, pose_of(oldest.pose.data())});
    nodes_.pop_front();
    for (const int64_t id : dropped_priors) {
      priors_.erase(id);
    }
  }
}

Eigen::Isometry3d EgocentricFactorGraph::T_map_odom() const {
  if (nodes_.empty()) {
    return Eigen::Isometry3d::Identity();
  }
  const Node& last = *nodes_.back();
  return pose_of(last.pose.data()) * last.T_odom_body.inverse();
}

}  // namespace liloc
