#include <ceres/loss_function.h>
#include <ceres/problem.h>
#include <ceres/solver.h>
#include <gtest/gtest.h>

#include <memory>
#include <random>

#include "factors/gravity_factor.hpp"
#include "factors/imu_factor.hpp"
#include "factors/imu_preintegration.hpp"
#include "factors/marginalization.hpp"
#include "factors/pose_prior_factor.hpp"
#include "factors/relative_pose_factor.hpp"
#include "factors/se3_manifold.hpp"
#include "math/so3.hpp"
#include "sim_drive.hpp"

namespace liloc {
namespace {

std::mt19937 rng(7);

Eigen::Isometry3d random_pose(double translation_m = 5.0, double rotation_rad = 1.0) {
  std::normal_distribution<double> n(0.0, 1.0);
  return se3::make(so3::exp(rotation_rad * Eigen::Vector3d(n(rng), n(rng), n(rng))),
                   translation_m * Eigen::Vector3d(n(rng), n(rng), n(rng)));
}

Eigen::VectorXd random_vector(int size, double sigma) {
  std::normal_distribution<double> n(0.0, sigma);
  Eigen::VectorXd v(size);
  for (int i = 0; i < size; ++i) {
    v(i) = n(rng);
  }
  return v;
}

Eigen::VectorXd evaluate(const ceres::CostFunction& cost, const std::vector<StateBlock>& blocks) {
  std::vector<const double*> parameters;
  for (const StateBlock& b : blocks) {
    parameters.push_back(b.data);
  }
  Eigen::VectorXd r(cost.num_residuals());
  EXPECT_TRUE(cost.Evaluate(parameters.data(), r.data(), nullptr));
  return r;
}

// The cost's Jacobians in tangent coordinates (its ambient ones times the manifold's
// PlusJacobian, as Ceres uses them) against central differences along the tangent.
void expect_jacobians_match_numeric(const ceres::CostFunction& cost,
                                    const std::vector<StateBlock>& blocks, double tolerance) {
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const int m = cost.num_residuals();
  std::vector<const double*> parameters;
  std::vector<RowMajor> J(blocks.size());
  std::vector<double*> jacobians;
  for (size_t i = 0; i < blocks.size(); ++i) {
    parameters.push_back(blocks[i].data);
    J[i].resize(m, blocks[i].size);
    jacobians.push_back(J[i].data());
  }
  Eigen::VectorXd r(m);
  ASSERT_TRUE(cost.Evaluate(parameters.data(), r.data(), jacobians.data()));
  const Se3Manifold manifold;
  const double h = 1e-6;
  for (size_t i = 0; i < blocks.size(); ++i) {
    const StateBlock& b = blocks[i];
    const Eigen::MatrixXd analytic = tangent_jacobian(J[i], b.data, b.pose);
    const std::vector<double> saved(b.data, b.data + b.size);
    for (int k = 0; k < b.tangent_size(); ++k) {
      Eigen::VectorXd residual[2];
      for (const int side : {0, 1}) {
        Eigen::VectorXd delta = Eigen::VectorXd::Zero(b.tangent_size());
        delta(k) = side == 0 ? -h : h;
        if (b.pose) {
          manifold.Plus(saved.data(), delta.data(), b.data);
        } else {
          for (int e = 0; e < b.size; ++e) {
            b.data[e] = saved[e] + delta(e);
          }
        }
        residual[side] = evaluate(cost, blocks);
        std::copy(saved.begin(), saved.end(), b.data);
      }
      const Eigen::VectorXd numeric = (residual[1] - residual[0]) / (2.0 * h);
      EXPECT_LT((numeric - analytic.col(k)).norm(), tolerance * std::max(1.0, numeric.norm()))
          << "block " << i << ", tangent coordinate " << k << "\nnumeric  " << numeric.transpose()
          << "\nanalytic " << analytic.col(k).transpose();
    }
  }
}

Matrix6d random_sqrt_information() {
  const Eigen::MatrixXd A = random_vector(36, 1.0).reshaped(6, 6);
  return Matrix6d(
      Eigen::MatrixXd(A.transpose() * A + 6.0 * Eigen::MatrixXd::Identity(6, 6)).llt().matrixU());
}

TEST(Se3Manifold, PlusMinusRoundTripAndJacobians) {
  const Se3Manifold manifold;
  for (int trial = 0; trial < 20; ++trial) {
    PoseBlock x = pose_block(random_pose());
    const Eigen::VectorXd delta = random_vector(6, 0.3);
    PoseBlock y;
    ASSERT_TRUE(manifold.Plus(x.data(), delta.data(), y.data()));
    // The right perturbation of math/se3.hpp.
    EXPECT_TRUE(pose_of(y.data()).isApprox(se3::plus(pose_of(x.data()), delta), 1e-12));
    Vector6d back;
    ASSERT_TRUE(manifold.Minus(y.data(), x.data(), back.data()));
    EXPECT_LT((back - delta).norm(), 1e-9);
    Eigen::Matrix<double, 7, 6, Eigen::RowMajor> P;
    Eigen::Matrix<double, 6, 7, Eigen::RowMajor> M;
    ASSERT_TRUE(manifold.PlusJacobian(x.data(), P.data()));
    ASSERT_TRUE(manifold.MinusJacobian(x.data(), M.data()));
    EXPECT_TRUE((M * P).isApprox(Matrix6d::Identity(), 1e-12));
    // PlusJacobian against central differences of Plus.
    for (int k = 0; k < 6; ++k) {
      Vector6d d = Vector6d::Zero();
      d(k) = 1e-6;
      PoseBlock up, down;
      manifold.Plus(x.data(), d.data(), up.data());
      d(k) = -1e-6;
      manifold.Plus(x.data(), d.data(), down.data());
      for (int e = 0; e < 7; ++e) {
        EXPECT_NEAR((up[e] - down[e]) / 2e-6, P(e, k), 1e-6);
      }
    }
  }
}

TEST(Factors, RelativePoseAndPosePriorJacobiansMatchNumeric) {
  for (int trial = 0; trial < 10; ++trial) {
    PoseBlock a = pose_block(random_pose()), b = pose_block(random_pose());
    const std::unique_ptr<ceres::CostFunction> relative(
        RelativePoseFactor::create(random_pose(), random_sqrt_information()));
    expect_jacobians_match_numeric(*relative, {{a.data(), 7, true}, {b.data(), 7, true}}, 1e-5);
    const std::unique_ptr<ceres::CostFunction> prior(
        PosePriorFactor::create(random_pose(), random_sqrt_information()));
    expect_jacobians_match_numeric(*prior, {{a.data(), 7, true}}, 1e-5);
  }
}

// The gravity factor: its Jacobians against numeric differentiation; zero where the body
// sees the map's down as measured; a tilt of the body by a small angle gives that angle
// over sigma, and a turn about gravity or a move gives nothing.
TEST(Factors, GravityFactorMeasuresTiltOnly) {
  for (int trial = 0; trial < 10; ++trial) {
    PoseBlock a = pose_block(random_pose());
    const std::unique_ptr<ceres::CostFunction> gravity(GravityFactor::create(
        random_vector(3, 1.0).normalized(), random_vector(3, 1.0).normalized(), 0.002));
    expect_jacobians_match_numeric(*gravity, {{a.data(), 7, true}}, 1e-5);
  }
  const Eigen::Vector3d down_map = Eigen::Vector3d(0.01, -0.02, -1.0).normalized();
  const Eigen::Isometry3d T = random_pose();
  const Eigen::Vector3d down_body = T.linear().transpose() * down_map;
  const std::unique_ptr<ceres::CostFunction> gravity(
      GravityFactor::create(down_map, down_body, 0.002));
  const auto residual = [&](const Eigen::Isometry3d& pose) {
    PoseBlock x = pose_block(pose);
    return evaluate(*gravity, {{x.data(), 7, true}});
  };
  EXPECT_LT(residual(T).norm(), 1e-9);
  const Eigen::Vector3d about_gravity = 0.3 * down_body;
  const Eigen::Vector3d across = down_body.unitOrthogonal() * 0.001;
  EXPECT_LT(residual(se3::plus(T, (Vector6d() << 1, 2, 3, about_gravity).finished())).norm(), 1e-9);
  EXPECT_NEAR(residual(se3::plus(T, (Vector6d() << 0, 0, 0, across).finished())).norm(), 0.5, 1e-3);
}

// At the measured relative pose the residual is zero; a perturbation xi of b's pose gives
// the residual sqrt_information * xi to first order (the convention of math/se3.hpp).
TEST(Factors, RelativePoseResidualIsTheRightPerturbation) {
  const Eigen::Isometry3d T_a = random_pose(), T_ab = random_pose(2.0, 0.5);
  const Matrix6d sqrt_information = random_sqrt_information();
  const std::unique_ptr<ceres::CostFunction> cost(
      RelativePoseFactor::create(T_ab, sqrt_information));
  PoseBlock a = pose_block(T_a), b = pose_block(T_a * T_ab);
  EXPECT_LT(evaluate(*cost, {{a.data(), 7, true}, {b.data(), 7, true}}).norm(), 1e-9);
  const Vector6d xi = random_vector(6, 1e-4);
  b = pose_block(se3::plus(T_a * T_ab, xi));
  const Eigen::VectorXd r = evaluate(*cost, {{a.data(), 7, true}, {b.data(), 7, true}});
  EXPECT_LT((r - sqrt_information * xi).norm(), 1e-6 * sqrt_information.norm());
}

// The odometry factor's noise (Eq. 7): both keyframes' pose covariances carried onto their
// relative pose. First order against a perturbation of a, then the whole covariance against
// the residuals of sampled poses.
TEST(Factors, RelativePoseCovarianceCarriesBothEnds) {
  const Eigen::Isometry3d T_a = random_pose(), T_ab = random_pose(2.0, 0.5);
  const std::unique_ptr<ceres::CostFunction> cost(
      RelativePoseFactor::create(T_ab, Matrix6d::Identity()));
  PoseBlock b = pose_block(T_a * T_ab);
  const Vector6d xi = random_vector(6, 1e-4);
  PoseBlock a = pose_block(se3::plus(T_a, xi));
  EXPECT_LT((evaluate(*cost, {{a.data(), 7, true}, {b.data(), 7, true}}) -
             relative_pose_jacobian_a(T_ab) * xi)
                .norm(),
            1e-7);

  const auto random_covariance = [](double sigma) {
    const Matrix6d root = random_sqrt_information().inverse() * sigma;
    return Matrix6d(root.transpose() * root);
  };
  const Matrix6d covariance_a = random_covariance(1e-3), covariance_b = random_covariance(2e-3);
  const Matrix6d expected = relative_pose_covariance(T_ab, covariance_a, covariance_b);
  const Eigen::LLT<Matrix6d> root_a(covariance_a), root_b(covariance_b);
  Matrix6d sampled = Matrix6d::Zero();
  const int samples = 20000;
  for (int k = 0; k < samples; ++k) {
    a = pose_block(se3::plus(T_a, root_a.matrixL() * random_vector(6, 1.0)));
    b = pose_block(se3::plus(T_a * T_ab, root_b.matrixL() * random_vector(6, 1.0)));
    const Vector6d r = evaluate(*cost, {{a.data(), 7, true}, {b.data(), 7, true}});
    sampled += r * r.transpose() / samples;
  }
  // Sampling error of 20 000 draws: about 1 % of the diagonal.
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) {
      EXPECT_NEAR(sampled(i, j), expected(i, j), 0.05 * std::sqrt(expected(i, i) * expected(j, j)))
          << i << ", " << j;
    }
  }
}

// The simulator's noise-free IMU on a 150 m drive.
struct NoiseFreeImu : test::NoiseFreeImuDrive {
  ImuNoiseDensities noise;
  explicit NoiseFreeImu(const Eigen::Vector3d& accel_bias = Eigen::Vector3d::Zero(),
                        const Eigen::Vector3d& gyro_bias = Eigen::Vector3d::Zero())
      : NoiseFreeImuDrive(0.1, accel_bias, gyro_bias) {
    noise.gravity_mps2 = gravity_mps2;
  }
};

// Preintegration over 10 s of a drive (turns included) against the simulator's truth.
TEST(ImuPreintegration, PredictsTenSecondsOfANoiseFreeDrive) {
  const NoiseFreeImu imu;
  const double t_i = 5.0, t_j = 15.0;
  ASSERT_GT(imu.trajectory->duration_s(), t_j);
  ImuPreintegration pre(ImuBias{}, imu.noise);
  const double gap_s =
      pre.integrate(imu.imu, static_cast<int64_t>(t_i * 1e6), static_cast<int64_t>(t_j * 1e6));
  EXPECT_NEAR(gap_s, 0.005, 1e-6);
  EXPECT_NEAR(pre.dt_s(), 10.0, 1e-9);
  const sim::VehicleState i = imu.trajectory->state(t_i), j = imu.trajectory->state(t_j);
  const Eigen::Matrix3d R_i = i.T_world_body.linear();
  const Eigen::Vector3d g(0, 0, -imu.noise.gravity_mps2);
  const double dt = pre.dt_s();
  const Eigen::Matrix3d R_j = R_i * pre.delta_R();
  const Eigen::Vector3d v_j = i.velocity_world + g * dt + R_i * pre.delta_v();
  const Eigen::Vector3d p_j = i.T_world_body.translation() + i.velocity_world * dt +
                              0.5 * g * dt * dt + R_i * pre.delta_p();
  // Midpoint integration of 5 ms pieces over 10 s.
  EXPECT_LT(so3::log(j.T_world_body.linear().transpose() * R_j).norm(), 2e-5);
  EXPECT_LT((v_j - j.velocity_world).norm(), 5e-4);
  EXPECT_LT((p_j - j.T_world_body.translation()).norm(), 2e-3);
  const double travelled = (j.T_world_body.translation() - i.T_world_body.translation()).norm();
  EXPECT_GT(travelled, 10.0);  // it moved: the check is not of a standing vehicle
}

// A bias change corrected to first order by the bias Jacobians, against integrating again.
TEST(ImuPreintegration, BiasJacobiansMatchIntegratingAgain) {
  const Eigen::Vector3d accel_bias(0.05, -0.08, 0.03), gyro_bias(0.004, -0.002, 0.003);
  const NoiseFreeImu imu(accel_bias, gyro_bias);
  const int64_t t_i = 5'000'000, t_j = 6'000'000;  // one second, as between keyframes
  ImuPreintegration at_zero(ImuBias{}, imu.noise);
  at_zero.integrate(imu.imu, t_i, t_j);
  const ImuBias truth{accel_bias, gyro_bias};
  ImuPreintegration at_truth(truth, imu.noise);
  at_truth.integrate(imu.imu, t_i, t_j);
  // First order: what is left is under 1 % of what the bias changed (uncorrected).
  const double R_uncorrected = so3::log(at_zero.delta_R().transpose() * at_truth.delta_R()).norm();
  const double v_uncorrected = (at_zero.delta_v() - at_truth.delta_v()).norm();
  const double p_uncorrected = (at_zero.delta_p() - at_truth.delta_p()).norm();
  EXPECT_GT(v_uncorrected, 0.05);
  EXPECT_LT(so3::log(at_zero.delta_R(truth).transpose() * at_truth.delta_R()).norm(),
            0.01 * R_uncorrected);
  EXPECT_LT((at_zero.delta_v(truth) - at_truth.delta_v()).norm(), 0.01 * v_uncorrected);
  EXPECT_LT((at_zero.delta_p(truth) - at_truth.delta_p()).norm(), 0.01 * p_uncorrected);
}

TEST(ImuFactor, ZeroAtTheTruthAndJacobiansMatchNumeric) {
  const NoiseFreeImu imu;
  const double t_i = 8.0, t_j = 9.0;
  ImuPreintegration pre(ImuBias{}, imu.noise);
  pre.integrate(imu.imu, static_cast<int64_t>(t_i * 1e6), static_cast<int64_t>(t_j * 1e6));
  const std::unique_ptr<ceres::CostFunction> cost(ImuFactor::create(pre, imu.noise.gravity_mps2));
  const sim::VehicleState i = imu.trajectory->state(t_i), j = imu.trajectory->state(t_j);
  PoseBlock pose_i = pose_block(i.T_world_body), pose_j = pose_block(j.T_world_body);
  Eigen::Vector3d v_i = i.velocity_world, v_j = j.velocity_world;
  Eigen::Matrix<double, 6, 1> b_i = Eigen::Matrix<double, 6, 1>::Zero(), b_j = b_i;
  Eigen::Vector2d tilt = Eigen::Vector2d::Zero();  // the simulator's world is level
  const std::vector<StateBlock> blocks{{pose_i.data(), 7, true}, {v_i.data(), 3, false},
                                       {b_i.data(), 6, false},   {pose_j.data(), 7, true},
                                       {v_j.data(), 3, false},   {b_j.data(), 6, false},
                                       {tilt.data(), 2, false}};
  // Whitened: within a few sigma at the truth (the preintegration's own discretization).
  EXPECT_LT(evaluate(*cost, blocks).norm(), 5.0);
  b_i = random_vector(6, 0.01);
  b_j = b_i + random_vector(6, 1e-4);
  pose_j = pose_block(se3::plus(j.T_world_body, random_vector(6, 0.05)));
  tilt = Eigen::Vector2d(0.02, -0.01);
  expect_jacobians_match_numeric(*cost, blocks, 1e-4);
}

// A chain of poses with relative-pose factors, an anchor and a loop (Cauchy): marginalizing
// the first two poses at the batch solution leaves a problem whose solution and information
// over the remaining poses are the batch's.
TEST(Marginalization, MatchesTheBatchSolution) {
  std::vector<Eigen::Isometry3d> truth{Eigen::Isometry3d::Identity()};
  for (int k = 1; k < 6; ++k) {
    truth.push_back(truth.back() * random_pose(1.0, 0.3));
  }
  std::vector<PoseBlock> x;
  for (const Eigen::Isometry3d& T : truth) {
    x.push_back(pose_block(se3::plus(T, random_vector(6, 0.1))));
  }
  std::vector<FactorRecord> factors;
  const auto block = [&](size_t k) { return StateBlock{x[k].data(), 7, true}; };
  factors.push_back({std::shared_ptr<ceres::CostFunction>(
                         PosePriorFactor::create(truth[0], 10.0 * Matrix6d::Identity())),
                     nullptr,
                     {block(0)}});
  for (size_t k = 1; k < x.size(); ++k) {
    const Eigen::Isometry3d noisy =
        se3::plus(truth[k - 1].inverse() * truth[k], random_vector(6, 0.02));
    factors.push_back({std::shared_ptr<ceres::CostFunction>(
                           RelativePoseFactor::create(noisy, random_sqrt_information())),
                       nullptr,
                       {block(k - 1), block(k)}});
  }
  factors.push_back({std::shared_ptr<ceres::CostFunction>(RelativePoseFactor::create(
                         se3::plus(truth[0].inverse() * truth[4], random_vector(6, 0.05)),
                         random_sqrt_information())),
                     std::make_shared<ceres::CauchyLoss>(1.0),
                     {block(0), block(4)}});
  const auto solve = [&](const std::vector<FactorRecord>& fs, std::vector<double>* H_diag) {
    ceres::Problem::Options options;
    options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(options);
    Se3Manifold manifold;
    for (const FactorRecord& f : fs) {
      std::vector<double*> blocks;
      for (const StateBlock& b : f.blocks) {
        blocks.push_back(b.data);
      }
      problem.AddResidualBlock(f.cost.get(), f.loss.get(), blocks);
      for (double* b : blocks) {
        problem.SetManifold(b, &manifold);
      }
    }
    ceres::Solver::Options solver;
    solver.function_tolerance = solver.gradient_tolerance = solver.parameter_tolerance = 1e-14;
    solver.max_num_iterations = 200;
    ceres::Solver::Summary summary;
    ceres::Solve(solver, &problem, &summary);
    ASSERT_TRUE(summary.IsSolutionUsable());
    // The information of poses 2..5 (tangent), the dropped poses' eliminated, as a vector.
    ceres::CRSMatrix J;
    ceres::Problem::EvaluateOptions evaluate;
    for (size_t k = 0; k < x.size(); ++k) {
      if (problem.HasParameterBlock(x[k].data())) {
        evaluate.parameter_blocks.push_back(x[k].data());
      }
    }
    problem.Evaluate(evaluate, nullptr, nullptr, nullptr, &J);
    Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(J.num_rows, J.num_cols);
    for (int row = 0; row < J.num_rows; ++row) {
      for (int e = J.rows[row]; e < J.rows[row + 1]; ++e) {
        dense(row, J.cols[e]) = J.values[e];
      }
    }
    const Eigen::MatrixXd H = dense.transpose() * dense;
    const int kept = 24, dropped = static_cast<int>(H.rows()) - kept;
    Eigen::MatrixXd H_star = H.bottomRightCorner(kept, kept);
    if (dropped > 0) {
      H_star -= H.bottomLeftCorner(kept, dropped) * H.topLeftCorner(dropped, dropped).inverse() *
                H.topRightCorner(dropped, kept);
    }
    H_diag->assign(H_star.data(), H_star.data() + H_star.size());
  };
  std::vector<double> batch_information;
  solve(factors, &batch_information);
  const std::vector<PoseBlock> batch = x;
  // Marginalize poses 0 and 1 at the batch solution; solve the rest from a perturbed start.
  const std::shared_ptr<MarginalPrior> prior = marginalize(factors, {x[0].data(), x[1].data()});
  ASSERT_NE(prior, nullptr);
  EXPECT_EQ(prior->blocks().size(), 2u);  // poses 2 (the chain) and 4 (the loop)
  EXPECT_EQ(prior->rank(), 12);
  std::vector<FactorRecord> reduced{prior->factor()};
  for (const FactorRecord& f : factors) {
    const bool drops = std::any_of(f.blocks.begin(), f.blocks.end(), [&](const StateBlock& b) {
      return b.data == x[0].data() || b.data == x[1].data();
    });
    if (!drops) {
      reduced.push_back(f);
    }
  }
  for (size_t k = 2; k < x.size(); ++k) {
    x[k] = pose_block(se3::plus(pose_of(x[k].data()), random_vector(6, 0.01)));
  }
  std::vector<double> reduced_information;
  solve(reduced, &reduced_information);
  for (size_t k = 2; k < x.size(); ++k) {
    EXPECT_LT(se3::minus(pose_of(x[k].data()), pose_of(batch[k].data())).norm(), 1e-6) << k;
  }
  const Eigen::Map<const Eigen::MatrixXd> expected(batch_information.data(), 24, 24);
  const Eigen::Map<const Eigen::MatrixXd> actual(reduced_information.data(), 24, 24);
  EXPECT_LT((expected - actual).norm(), 1e-6 * expected.norm());
  // The prior's Jacobians, as a factor, against numeric differentiation.
  expect_jacobians_match_numeric(*prior->factor().cost, prior->blocks(), 1e-5);
}

}  // namespace
}  // namespace liloc
