#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <iterator>
#include <optional>
#include <random>
#include <variant>

#include "eval/trajectory_metrics.hpp"
#include "math/se3.hpp"
#include "math/so3.hpp"
#include "odometry/extrinsic_check.hpp"
#include "odometry/imu_propagation.hpp"
#include "odometry/lidar_inertial_odometry.hpp"
#include "odometry/scan_deskewer.hpp"
#include "odometry/search_answer.hpp"
#include "sim/imu_simulator.hpp"
#include "sim/lidar_model.hpp"
#include "sim/random.hpp"
#include "sim/session_planner.hpp"
#include "sim/session_recipe.hpp"
#include "sim/session_simulator.hpp"
#include "sim/simulation_config.hpp"
#include "sim/world_generator.hpp"

namespace liloc {
namespace {

// A body turning at 1 rad/s while driving 10 m/s: each point is measured from where the
// body was at its own time; deskewing with the true motion must place it exactly.
TEST(Deskew, UndoesAKnownMotionOnAKnownCloud) {
  const Eigen::Vector3d omega(0.0, 0.0, 1.0);
  const Eigen::Vector3d v_body(10.0, 0.0, 0.0);
  const auto T_local_body = [&](double t) {
    // Constant twist: exact with one motion sample (constant rates, zero acceleration in
    // the body frame means a circular arc; use the closed form of se3::exp).
    Vector6d xi;
    xi << v_body * t, omega * t;
    return se3::exp(xi);
  };
  const Eigen::Isometry3d T_body_lidar =
      se3::make(so3::exp(Eigen::Vector3d(0.0, 0.0, 0.3)), Eigen::Vector3d(0.2, 0.0, 0.5));
  const int64_t start = 1000000, end = 1100000;
  // The motion profile as the IMU integrator builds it: fine samples.
  MotionProfile motion;
  for (int64_t t = start; t <= end; t += 1000) {
    const double s = (t - start) * 1e-6;
    const Eigen::Isometry3d T = T_local_body(s);
    motion.add({t, T.linear(), T.translation(), T.linear() * v_body, omega,
                T.linear() * omega.cross(v_body)});
  }
  std::vector<LidarPoint> points;
  std::vector<Eigen::Vector3d> world;
  for (int i = 0; i < 100; ++i) {
    const double time = 0.001 * i;
    const Eigen::Vector3d w(20.0 * std::cos(0.06 * i), 20.0 * std::sin(0.06 * i), 1.0 + 0.01 * i);
    const Eigen::Isometry3d T_local_lidar = T_local_body(time) * T_body_lidar;
    LidarPoint p;
    p.position_m = (T_local_lidar.inverse() * w).cast<float>();
    p.time_offset_s = static_cast<float>(time);
    points.push_back(p);
    world.push_back(w);
  }
  const std::vector<Eigen::Vector3f> out = deskew(points, start, end, motion, T_body_lidar);
  const Eigen::Isometry3d T_end_local = T_local_body(0.1).inverse();
  double worst = 0.0;
  for (size_t i = 0; i < out.size(); ++i) {
    worst = std::max(worst, (out[i].cast<double>() - T_end_local * world[i]).norm());
  }
  EXPECT_LT(worst, 2e-3);
  // Without deskewing, the points would be off by up to the 1 m driven in the sweep.
  MotionProfile still;
  still.add({start, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(),
             Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()});
  const std::vector<Eigen::Vector3f> skewed = deskew(points, start, end, still, T_body_lidar);
  double skew = 0.0;
  for (size_t i = 0; i < out.size(); ++i) {
    skew = std::max(skew, (skewed[i].cast<double>() - T_end_local * world[i]).norm());
  }
  EXPECT_GT(skew, 0.5);
}

// Noise-free IMU samples of a simulated drive, propagated from the true state, follow the
// true trajectory; the propagated covariance grows.
TEST(ImuPropagation, FollowsTheTrueTrajectory) {
  const sim::GeneratedWorld g = sim::generate_world(sim::WorldConfig{});
  sim::SessionPlanConfig lengths;
  lengths.a_length_m = 300.0;
  const sim::SessionPlan plan = sim::plan_session("A", g.world, g.mapped_max_x_m, lengths, 3);
  const sim::VehicleTrajectory trajectory(g.world, plan.waypoints, sim::MotionConfig{}, 3);
  sim::ImuConfig clean;
  clean.accel_noise_density = clean.gyro_noise_density = 0.0;
  clean.accel_bias_random_walk = clean.gyro_bias_random_walk = 0.0;
  clean.initial_accel_bias_sigma_mps2 = clean.initial_gyro_bias_sigma_rps = 0.0;
  sim::ImuSimulator imu(trajectory, clean, 1, 0);
  std::vector<ImuSample> samples;
  while (imu.next_time_s() < 20.0) {
    samples.push_back(imu.next());
  }
  const double t0 = 8.0, t1 = 18.0;
  const sim::VehicleState s0 = trajectory.state(t0);
  NavState x;
  x.R = s0.T_world_body.linear();
  x.p = s0.T_world_body.translation();
  x.v = s0.velocity_world;
  x.g = Eigen::Vector3d(0, 0, -clean.gravity_mps2);
  StateMatrix P = StateMatrix::Identity() * 1e-6;
  std::vector<ImuSample> window;
  for (const ImuSample& s : samples) {
    if (s.utime_us >= 7990000 && s.utime_us <= 18000000) {
      window.push_back(s);
    }
  }
  MotionProfile motion;
  const PropagationStats stats =
      propagate(x, P, 8000000, 18000000, window, ImuNoiseConfig{}, &motion);
  const Eigen::Isometry3d truth = trajectory.pose(t1);
  EXPECT_EQ(stats.gaps, 0);
  EXPECT_LT((x.p - truth.translation()).norm(), 0.05);
  EXPECT_LT(so3::log(truth.linear().transpose() * x.R).norm(), 1e-3);
  EXPECT_LT((x.v - trajectory.state(t1).velocity_world).norm(), 0.01);
  EXPECT_GT(P(kPos, kPos), 1e-6);
  // The motion profile reproduces the poses in between.
  EXPECT_LT((motion.pose_at(13000000).translation() - trajectory.pose(13.0).translation()).norm(),
            0.03);
}

// The error-state transition inside propagate() is the Jacobian of the nominal
// propagation in the state's own perturbation (pose on the right, math/se3.hpp): numeric
// differences of propagate() through boxplus / boxminus carry any covariance P0 to the
// same P as the filter does.
TEST(ImuPropagation, CovarianceFollowsTheNumericJacobianOfThePropagation) {
  NavState x0;
  x0.R = so3::exp(Eigen::Vector3d(0.1, -0.2, 0.7));
  x0.p = Eigen::Vector3d(3, -1, 0.5);
  x0.v = Eigen::Vector3d(4, 1, -0.2);
  x0.bg = Eigen::Vector3d(0.01, -0.02, 0.005);
  x0.ba = Eigen::Vector3d(0.05, 0.02, -0.03);
  x0.g = so3::exp(Eigen::Vector3d(0.02, -0.01, 0)) * Eigen::Vector3d(0, 0, -9.81);
  std::vector<ImuSample> samples;
  for (int k = 0; k <= 50; ++k) {  // 0.5 s at 100 Hz, turning and accelerating
    const double t = k * 0.01;
    samples.push_back({k * 10000, Eigen::Vector3d(0.3 * std::sin(t), 0.8, 9.6 + std::cos(3 * t)),
                       Eigen::Vector3d(0.1, -0.3 * t, 0.6 + 0.2 * std::sin(2 * t))});
  }
  ImuNoiseConfig silent;  // no process noise: P0 is only carried
  silent.accel_noise_density = silent.gyro_noise_density = 1e-12;
  silent.accel_bias_random_walk = silent.gyro_bias_random_walk = 0.0;
  silent.gravity_direction_random_walk = 0.0;
  const auto run = [&](const NavState& start) {
    NavState x = start;
    StateMatrix unused = StateMatrix::Zero();
    propagate(x, unused, 0, 500000, samples, silent, nullptr);
    return x;
  };
  const NavState x1 = run(x0);
  StateMatrix F_numeric;
  const double eps = 1e-6;
  for (int j = 0; j < kStateDim; ++j) {
    StateVector dx = StateVector::Zero();
    dx(j) = eps;
    const StateVector plus = boxminus(run(boxplus(x0, dx)), x1);
    const StateVector minus = boxminus(run(boxplus(x0, -dx)), x1);
    F_numeric.col(j) = (plus - minus) / (2 * eps);
  }
  // A covariance with every block coupled.
  StateMatrix L = StateMatrix::Zero();
  for (int i = 0; i < kStateDim; ++i) {
    for (int j = 0; j <= i; ++j) {
      L(i, j) = i == j ? 1.0 + 0.1 * i : 0.3 * std::sin(1.0 + i * 7 + j * 3);
    }
  }
  StateMatrix P = L * L.transpose();
  const StateMatrix expected = F_numeric * P * F_numeric.transpose();
  NavState x = x0;
  propagate(x, P, 0, 500000, samples, silent, nullptr);
  EXPECT_LT((P - expected).norm(), 1e-4 * expected.norm()) << (P - expected);
}

TEST(NavState, BoxminusInvertsBoxplus) {
  NavState x;
  x.R = so3::exp(Eigen::Vector3d(0.3, 0.1, -1.2));
  x.p = Eigen::Vector3d(1, 2, 3);
  x.g = so3::exp(Eigen::Vector3d(0.05, 0, 0)) * Eigen::Vector3d(0, 0, -9.81);
  StateVector dx;
  for (int i = 0; i < kStateDim; ++i) {
    dx(i) = 0.01 * (i + 1) * (i % 2 == 0 ? 1 : -1);
  }
  EXPECT_TRUE(boxminus(boxplus(x, dx), x).isApprox(dx, 1e-9));
}

// The body-frame gravity and its spread: states drawn from a covariance that couples the
// attitude with the gravity direction give the directions body_gravity predicts, with the
// spread of its larger axis (within 5 %).
TEST(NavState, BodyGravityCarriesTheAttitudeAndGravityCovariance) {
  NavState x;
  x.R = so3::exp(Eigen::Vector3d(0.2, -0.1, 2.0));
  x.g = so3::exp(Eigen::Vector3d(0.03, 0.01, 0)) * Eigen::Vector3d(0, 0, -9.81);
  StateMatrix L = StateMatrix::Identity() * 1e-3;
  for (int i = kRot; i < kStateDim; ++i) {
    for (int j = kRot; j < i; ++j) {
      L(i, j) = 5e-4 * std::sin(1.0 + i * 7 + j * 3);
    }
  }
  const StateMatrix P = L * L.transpose();
  const BodyGravity predicted = body_gravity(x, P);
  EXPECT_TRUE(predicted.direction.isApprox(x.R.transpose() * x.g.normalized(), 1e-12));
  std::mt19937 rng(7);
  std::normal_distribution<double> normal;
  Eigen::Matrix3d spread = Eigen::Matrix3d::Zero();
  const int n = 20000;
  for (int k = 0; k < n; ++k) {
    StateVector z;
    for (int i = 0; i < kStateDim; ++i) {
      z(i) = normal(rng);
    }
    const NavState y = boxplus(x, L * z);
    const Eigen::Vector3d d = y.R.transpose() * y.g.normalized() - predicted.direction;
    spread += d * d.transpose() / n;
  }
  const double sampled =
      std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(spread).eigenvalues()(2));
  EXPECT_NEAR(predicted.sigma_rad, sampled, 0.05 * sampled);
  EXPECT_GT(predicted.sigma_rad, 1e-3);
}

// Sweep `index` of a simulated model, every ray returning from 20 m; with `blocked`, only
// the rays above the horizon.
LidarScan sweep_of(const std::string& model, int64_t index, bool blocked = false) {
  LidarScan scan;
  scan.utime_us = 1'000'000 + index * 100'000;
  for (const sim::LidarRay& ray : sim::sweep_rays(sim::lidar_spec(model), index)) {
    if (blocked && ray.direction.z() <= 0.0f) {
      continue;
    }
    LidarPoint p;
    p.position_m = 20.0f * ray.direction;
    p.time_offset_s = ray.time_offset_s;
    p.ring = ray.ring;
    scan.points.push_back(p);
  }
  return scan;
}

// What the odometry adapted to a simulated model's rings from its first sweep, with a
// standing IMU or without one.
std::string ring_adaptation_of(LidarInertialOdometry& odometry, const OdometryConfig& config,
                               const std::string& model) {
  if (config.use_imu) {
    for (int64_t t_us = 300'000; t_us <= 1'200'000; t_us += 5'000) {
      odometry.add_imu(
          {t_us, Eigen::Vector3d(0.0, 0.0, config.imu.gravity_mps2), Eigen::Vector3d::Zero()});
    }
  }
  odometry.add_scan(sweep_of(model, 0));
  const std::vector<OdometryEstimate> out = odometry.process();
  EXPECT_EQ(out.size(), 1u) << model;
  return out.empty() ? std::string() : out.front().ring_adaptation;
}

// The cut for planes seen edge-on chosen from one sweep of a simulated model, with a
// standing IMU or without one; the ring spacings as configured by default, else these
// (with the IMU and without).
double chosen_incidence_cut(const std::string& model, bool use_imu,
                            std::optional<double> ring_spacings = std::nullopt) {
  OdometryConfig config;
  config.use_imu = use_imu;
  if (ring_spacings) {
    config.grazing_ring_spacings = config.grazing_ring_spacings_without_imu = *ring_spacings;
  }
  LidarInertialOdometry odometry(config);
  const std::string adaptation = ring_adaptation_of(odometry, config, model);
  EXPECT_EQ(adaptation.find("cosine of incidence") == std::string::npos,
            ring_spacings.has_value() && *ring_spacings <= 0.0)
      << model;
  return odometry.min_incidence_cos();
}

// The HDL-32E's search after a 0.4 s gap in which a turn began (campus A without an IMU,
// irregular pattern 0, at 95.6 s): the sweep, deskewed as if the vehicle drove straight,
// fitted every answer loosely. Its five answers, inliers per 1000 points and prior densities:
// by count it was placed 2.2 m from the prediction, which was 5 cm from the truth; the
// answer the prior takes among those that fit alike is 0.15 m and 3 degrees from the truth.
TEST(SearchAnswer, AClearlyLikelierAnswerIsTakenOfThoseThatFitAlike) {
  const std::vector<SearchCandidate> answers{
      {336, 0.981}, {336, 0.419}, {344, 0.909}, {348, 0.0175}, {300, 0.809}};
  EXPECT_EQ(pick_search_answer(answers, 0.95, 10.0), 0u);
  EXPECT_EQ(pick_search_answer(answers, 1.0, 10.0), 3u);    // only equal counts alike
  EXPECT_EQ(pick_search_answer(answers, 0.95, 100.0), 3u);  // 56 times is not enough
  // An answer that fits clearly more is taken however far from its guess.
  EXPECT_EQ(pick_search_answer({{500, 0.01}, {400, 1.0}}, 0.95, 10.0), 0u);
  // A prior only somewhat stronger does not overrule the count: after a sweep placed off,
  // the next search's prior is off too.
  EXPECT_EQ(pick_search_answer({{549, 0.55}, {530, 1.0}}, 0.95, 10.0), 0u);
  // Priors alike too (far beyond their guesses, both densities 0): the count.
  EXPECT_EQ(pick_search_answer({{530, 0.0}, {549, 0.0}}, 0.95, 10.0), 1u);
  // Equal counts: the likelier. At the bounds (95 % of the count, 10 times as likely) the
  // prior decides; just inside them, the count.
  EXPECT_EQ(pick_search_answer({{500, 0.5}, {500, 1.0}}, 0.95, 10.0), 1u);
  EXPECT_EQ(pick_search_answer({{400, 0.1}, {380, 1.0}}, 0.95, 10.0), 1u);
  EXPECT_EQ(pick_search_answer({{400, 0.1}, {379, 1.0}}, 0.95, 10.0), 0u);
  EXPECT_EQ(pick_search_answer({{400, 0.11}, {380, 1.0}}, 0.95, 10.0), 0u);
}

TEST(LidarInertialOdometry, LowersTheGrazingCutWhereTheLidarSamplesItsHorizonFinely) {
  // With the IMU, 3 ring spacings. VLP-16 rings 2 degrees apart: sin(6 deg) is above the
  // configured 0.1, which stays.
  EXPECT_DOUBLE_EQ(chosen_incidence_cut("vlp16", true), 0.1);
  // HDL-32E: 1.33 degrees.
  const double hdl32_step_rad = 41.34 / 31.0 / so3::kRadToDeg;
  EXPECT_NEAR(chosen_incidence_cut("hdl32", true), std::sin(3.0 * hdl32_step_rad), 1e-4);
  // OS1-64 (0.53 degrees) and the Mid-360's non-repetitive pattern: the floor.
  EXPECT_DOUBLE_EQ(chosen_incidence_cut("os1_64", true), 0.05);
  EXPECT_DOUBLE_EQ(chosen_incidence_cut("mid360", true), 0.05);
  // Without it, 5: the HDL-32E keeps the configured cut, the finer LiDARs get the floor.
  EXPECT_DOUBLE_EQ(chosen_incidence_cut("hdl32", false), 0.1);
  EXPECT_NEAR(chosen_incidence_cut("hdl32", false, 4.0), std::sin(4.0 * hdl32_step_rad), 1e-4);
  EXPECT_DOUBLE_EQ(chosen_incidence_cut("os1_64", false), 0.05);
  EXPECT_DOUBLE_EQ(chosen_incidence_cut("vlp16", false), 0.1);
  // 0: the cut as configured.
  EXPECT_DOUBLE_EQ(chosen_incidence_cut("mid360", true, 0.0), 0.1);
  EXPECT_DOUBLE_EQ(chosen_incidence_cut("mid360", false, 0.0), 0.1);
}

// Far ceilings are left out beyond the range where the rings' elevation steps open wider
// than the association radius (0.5 m / 2 deg = 14.3 m for the VLP-16), without an IMU by
// default; never for a LiDAR whose steps stay fine to its range (the Mid-360).
TEST(LidarInertialOdometry, LeavesOutFarCeilingsBeyondWhatTheRingsResolve) {
  const auto adaptation = [](const std::string& model, bool use_imu, bool with_imu_too) {
    OdometryConfig config;
    config.use_imu = use_imu;
    config.far_ceilings_left_out = with_imu_too;
    LidarInertialOdometry odometry(config);
    return ring_adaptation_of(odometry, config, model);
  };
  const std::string ceilings = "planes near level above the LiDAR beyond ";
  EXPECT_NE(adaptation("vlp16", false, false).find(ceilings + "14.3 m"), std::string::npos)
      << adaptation("vlp16", false, false);
  EXPECT_NE(adaptation("hdl32", false, false).find(ceilings + "21.5 m"), std::string::npos);
  EXPECT_EQ(adaptation("vlp16", true, false).find(ceilings), std::string::npos);
  EXPECT_NE(adaptation("vlp16", true, true).find(ceilings + "14.3 m"), std::string::npos);
  EXPECT_EQ(adaptation("mid360", false, false).find(ceilings), std::string::npos);
}

TEST(LidarInertialOdometry, KeepsTheConfiguredGrazingCutUntilASweepShowsTheHorizon) {
  OdometryConfig config;
  config.use_imu = false;
  LidarInertialOdometry odometry(config);
  odometry.add_scan(sweep_of("mid360", 0, true));
  std::vector<OdometryEstimate> out = odometry.process();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_TRUE(out.front().ring_adaptation.empty());
  EXPECT_DOUBLE_EQ(odometry.min_incidence_cos(), 0.1);
  odometry.add_scan(sweep_of("mid360", 1));
  out = odometry.process();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NE(out.front().ring_adaptation.find("0.050"), std::string::npos)
      << out.front().ring_adaptation;
  EXPECT_DOUBLE_EQ(odometry.min_incidence_cos(), 0.05);
}

// A simulated drive, recorded once in memory: every IMU sample and sweep in the order a
// live robot would deliver them, with its ground truth and the true biases.
struct Recording {
  std::vector<std::variant<ImuSample, LidarScan>> events;
  Trajectory ground_truth;
  Eigen::Vector3d accel_bias, gyro_bias;
  sim::SimulationConfig config;
  double length_m = 0.0;
  // Seconds since the drive's start.
  double seconds(int64_t utime_us) const { return (utime_us - config.start_utime) * 1e-6; }
};

// Simulates r's drive along waypoints in world, with r.config's rig and IMU.
void simulate(Recording& r, const sim::World& world, const std::vector<Eigen::Vector2d>& waypoints,
              const std::string& lidar, uint64_t seed, int64_t start_utime) {
  const sim::VehicleTrajectory trajectory(world, waypoints, r.config.motion, seed);
  const sim::SessionSimulator sim(world, trajectory, sim::lidar_spec(lidar), r.config.rig.rig(),
                                  r.config.imu, seed, start_utime);
  sim.run([&](const ImuSample& s) { r.events.emplace_back(s); },
          [&](const LidarScan& s) { r.events.emplace_back(s); }, [](double) {}, 2);
  r.ground_truth = sim.ground_truth(100.0);
  r.accel_bias = sim.initial_accel_bias();
  r.gyro_bias = sim.initial_gyro_bias();
  r.length_m = trajectory.length_m();
}

Recording record(const std::string& world_kind, std::vector<Eigen::Vector2d> waypoints = {},
                 const std::string& lidar = "vlp16") {
  Recording r;
  r.config.world.kind = world_kind;
  // Larger turn-on biases than the defaults, so that recovering them means something.
  r.config.imu.initial_accel_bias_sigma_mps2 = 0.1;
  r.config.imu.initial_gyro_bias_sigma_rps = 0.01;
  const sim::GeneratedWorld g = sim::generate_world(r.config.world);
  if (waypoints.empty()) {
    const std::vector<Eigen::Vector2d>& nodes = g.world.roads().nodes();
    // Around one block of the campus: 4 corners, about 270 m.
    waypoints = {nodes[0], nodes[1], nodes[6], nodes[5], nodes[0]};
  }
  simulate(r, g.world, waypoints, lidar, 11, r.config.start_utime);
  return r;
}

// The start of a campus session as bench_odometry simulates it (its first waypoints).
Recording record_session_start(int64_t world_seed, const std::string& session, size_t waypoints,
                               const std::string& lidar) {
  Recording r;
  r.config.world.seed = world_seed;
  const sim::SimulatedSessions sessions(r.config);
  const sim::SimulatedSession recipe = sessions.session(session);
  const std::vector<Eigen::Vector2d>& route = recipe.plan.waypoints;
  simulate(r, *recipe.world,
           {route.begin(),
            route.begin() + static_cast<std::ptrdiff_t>(std::min(waypoints, route.size()))},
           lidar, recipe.seed, recipe.start_utime);
  r.config.start_utime = recipe.start_utime;
  return r;
}

const Recording& campus_drive() {
  static const Recording r = record("campus");
  return r;
}

OdometryConfig config_for(const Recording& r, bool use_imu = true) {
  OdometryConfig c;
  c.use_imu = use_imu;
  c.lidar_translation_m = r.config.rig.lidar_translation_m;
  c.lidar_rpy_deg = r.config.rig.lidar_rpy_deg;
  return c;
}

struct Replayed {
  std::vector<OdometryEstimate> estimates;
  Trajectory trajectory() const {
    std::vector<StampedPose> poses;
    for (const OdometryEstimate& e : estimates) {
      poses.push_back({e.utime_us * 1e-6, e.T_odom_body});
    }
    return Trajectory(poses);
  }
  eval::TrajectoryMetrics metrics(const Recording& r) const {
    return eval::evaluate_trajectory(r.ground_truth, trajectory(), eval::EvalConfig{});
  }
  // The first estimate that says it is lost, or nullptr.
  const OdometryEstimate* first_lost() const {
    const auto lost =
        std::find_if(estimates.begin(), estimates.end(),
                     [](const OdometryEstimate& e) { return !e.lost_reason.empty(); });
    return lost == estimates.end() ? nullptr : &*lost;
  }
  // The odometry frame in the truth's, the two aligned at the first estimate.
  Eigen::Isometry3d T_truth_odom(const Recording& r) const {
    return *r.ground_truth.at(estimates.front().utime_us * 1e-6, 0.5);
  }
  // The estimate's position minus the truth's, in the truth's frame.
  Eigen::Vector3d position_error(const Recording& r, const OdometryEstimate& e) const {
    return (T_truth_odom(r) * e.T_odom_body).translation() -
           r.ground_truth.at(e.utime_us * 1e-6, 0.5)->translation();
  }
  // The estimate's orientation error (the truth's body to the estimate's) as roll, pitch and
  // yaw (rad).
  Eigen::Vector3d rpy_error_rad(const Recording& r, const OdometryEstimate& e) const {
    return so3::to_rpy(r.ground_truth.at(e.utime_us * 1e-6, 0.5)->linear().transpose() *
                       T_truth_odom(r).linear() * e.T_odom_body.linear());
  }
  // Between a_s and b_s after the start (seconds) the estimate moves as the truth does,
  // within 3 % of the distance (more than 30 m).
  void expect_moves_as_truth(const Recording& r, double a_s, double b_s) const {
    const Trajectory estimate = trajectory();
    const double a = r.config.start_utime * 1e-6 + a_s, b = r.config.start_utime * 1e-6 + b_s;
    const Eigen::Isometry3d moved_est = estimate.at(a, 0.5)->inverse() * *estimate.at(b, 0.5);
    const Eigen::Isometry3d moved_truth =
        r.ground_truth.at(a, 0.5)->inverse() * *r.ground_truth.at(b, 0.5);
    EXPECT_GT(moved_truth.translation().norm(), 30.0);
    EXPECT_LT((moved_est.translation() - moved_truth.translation()).norm(),
              0.03 * moved_truth.translation().norm());
  }
};

// Feeds the events (after `edit`, which may drop or change them) to the odometry.
template <class Edit>
Replayed replay(const Recording& r, LidarInertialOdometry& odometry, Edit edit) {
  Replayed run;
  for (auto event : r.events) {
    if (!edit(event)) {
      continue;
    }
    if (auto* s = std::get_if<ImuSample>(&event)) {
      odometry.add_imu(*s);
    } else {
      odometry.add_scan(std::get<LidarScan>(event));
    }
    for (OdometryEstimate& e : odometry.process()) {
      run.estimates.push_back(std::move(e));
    }
  }
  for (OdometryEstimate& e : odometry.flush()) {
    run.estimates.push_back(std::move(e));
  }
  return run;
}

Replayed replay(const Recording& r, LidarInertialOdometry& odometry) {
  return replay(r, odometry, [](auto&) { return true; });
}

// Replays with every IMU sample passed through fault(seconds since the start, sample).
template <class Fault>
Replayed replay_with_imu_fault(const Recording& r, LidarInertialOdometry& odometry, Fault fault) {
  return replay(r, odometry, [&](std::variant<ImuSample, LidarScan>& e) {
    if (ImuSample* imu = std::get_if<ImuSample>(&e)) {
      fault(r.seconds(imu->utime_us), *imu);
    }
    return true;
  });
}

// Replays every IMU sample and the sweeps whose time since the start (s) keep accepts.
template <class Keep>
Replayed replay_sweeps(const Recording& r, LidarInertialOdometry& odometry, Keep keep) {
  return replay(r, odometry, [&](const std::variant<ImuSample, LidarScan>& e) {
    const LidarScan* scan = std::get_if<LidarScan>(&e);
    return scan == nullptr || keep(r.seconds(scan->utime_us));
  });
}

// Replays with the gyro's z reading off by step_rps from 30 s to the end.
Replayed replay_with_gyro_step(const Recording& r, LidarInertialOdometry& odometry,
                               double step_rps) {
  return replay_with_imu_fault(r, odometry, [step_rps](double t, ImuSample& imu) {
    if (t > 30.0) {
      imu.gyro_rps.z() += step_rps;
    }
  });
}

TEST(Odometry, TracksASimulatedDriveAndRecoversTheBiases) {
  const Recording& r = campus_drive();
  LidarInertialOdometry odometry(config_for(r));
  const Replayed run = replay(r, odometry);
  const eval::TrajectoryMetrics m = run.metrics(r);
  EXPECT_GT(m.path_length_m, 200.0);
  EXPECT_LT(m.rpe_translation_percent, 1.0);
  EXPECT_LT(m.ate_position_rmse_m, 0.3);
  // Turn-on biases, drawn with sigma 0.1 m/s^2 and 0.01 rad/s; their random walk over
  // the drive is a few 1e-3 m/s^2 and 1e-4 rad/s.
  const Eigen::Vector3d ba_error = odometry.state().ba - r.accel_bias;
  const Eigen::Vector3d bg_error = odometry.state().bg - r.gyro_bias;
  EXPECT_LT(bg_error.norm(), 1e-3)
      << "true " << r.gyro_bias.transpose() << " estimated " << odometry.state().bg.transpose();
  EXPECT_LT(bg_error.norm(), 0.2 * r.gyro_bias.norm());
  EXPECT_LT(ba_error.norm(), 0.03)
      << "true " << r.accel_bias.transpose() << " estimated " << odometry.state().ba.transpose();
  EXPECT_LT(ba_error.norm(), 0.3 * r.accel_bias.norm());
  // A healthy drive trips neither the health monitor nor the IMU consistency test.
  EXPECT_EQ(odometry.counters().health_resets, 0);
  EXPECT_EQ(odometry.counters().imu_disagreements, 0);
  // Keyframes every metre or 0.2 rad, with clouds.
  int keyframes = 0;
  for (const OdometryEstimate& e : run.estimates) {
    if (e.keyframe) {
      ++keyframes;
      EXPECT_GT(e.keyframe->cloud_body.size(), 1000u);
    }
  }
  EXPECT_GT(keyframes, static_cast<int>(0.5 * m.path_length_m / 1.0));
  EXPECT_LT(keyframes, static_cast<int>(1.5 * m.path_length_m / 1.0) + 20);
}

TEST(Odometry, LidarOnlyModeAlsoTracks) {
  const Recording& r = campus_drive();
  LidarInertialOdometry odometry(config_for(r, false));
  const eval::TrajectoryMetrics m = replay(r, odometry).metrics(r);
  EXPECT_LT(m.rpe_translation_percent, 3.0);
  EXPECT_LT(m.ate_position_rmse_m, 2.0);
}

// Sweeps spaced irregularly (two of every three dropped, 0.3 s apart): the LiDAR-only
// motion model's velocity is the motion over the time since the previous sweep, which the
// prediction covers, not over a sweep's own duration (that made it three times too fast).
TEST(Odometry, LidarOnlyModeTracksSweepsSpacedIrregularly) {
  const Recording& r = campus_drive();
  LidarInertialOdometry odometry(config_for(r, false));
  int sweeps = 0;
  const Replayed run = replay(r, odometry, [&](const auto& event) {
    return !std::holds_alternative<LidarScan>(event) || sweeps++ % 3 == 0;
  });
  const eval::TrajectoryMetrics m = run.metrics(r);
  EXPECT_GT(m.path_length_m, 200.0);
  EXPECT_LT(m.rpe_translation_percent, 3.0);
  EXPECT_LT(m.ate_position_rmse_m, 2.0);
}

// Pauses of 4 s every 15 s without an IMU (at the campus's speeds, 20-30 m and, in the
// corners, tens of degrees between two sweeps): the search places each sweep after a pause
// in the local map, confirmed by its starts' agreement where it sees far ahead of the map,
// and the last rotation rate is not carried across the pause (a roll or pitch rate
// extrapolated over seconds tilted the restart by tens of degrees).
TEST(Odometry, LidarOnlyModeBridgesPausesOfSeconds) {
  const Recording& r = campus_drive();
  LidarInertialOdometry odometry(config_for(r, false));
  const Replayed run = replay(r, odometry, [&](const std::variant<ImuSample, LidarScan>& e) {
    const LidarScan* scan = std::get_if<LidarScan>(&e);
    return scan == nullptr || std::fmod(r.seconds(scan->utime_us), 15.0) < 11.0;
  });
  EXPECT_EQ(odometry.counters().map_restarts, 0);
  EXPECT_GT(odometry.counters().searched_scans, 0);
  const eval::TrajectoryMetrics m = run.metrics(r);
  EXPECT_GT(m.path_length_m, 200.0);
  LidarInertialOdometry every_sweep(config_for(r, false));
  EXPECT_LT(m.ate_position_rmse_m, 2.0 * replay(r, every_sweep).metrics(r).ate_position_rmse_m);
  for (const OdometryEstimate& e : run.estimates) {
    const Eigen::Vector3d rpy_error = run.rpy_error_rad(r, e);
    ASSERT_LT(std::abs(rpy_error.x()), 0.05) << "roll at " << e.utime_us;
    ASSERT_LT(std::abs(rpy_error.y()), 0.05) << "pitch at " << e.utime_us;
  }
}

// Without an IMU, the last sweep before a pause of 4 s is registered 0.6 m sideways (its
// points shifted: a poorly fitting sweep in a turn). Carried across the pause, that sweep's
// 6 m/s sideways put the prediction beyond the search's reach, and the estimate stayed 26 m
// off (re-anchoring or not); the prediction with the velocity of the last second, searched
// too, is within reach, and the drive after the pause is nearly as accurate as without the
// pause: the largest error 4-14 s after it 0.56 m against 0.44 m for the drive without it
// (0.66 against 0.67 m with sweeps deskewed once, poor_fit_deskew_passes 0: deskewing
// again gains more on the drive without the pause). With far ceilings left out
// (far_ceilings_left_out_without_imu) the drive without the pause is 0.12 m off and the
// drive after it 0.57 m, as before: the bound is now on the latter alone.
TEST(Odometry, LidarOnlyAcrossAPauseTheLastSecondsVelocityIsASecondGuess) {
  const Recording& r = campus_drive();
  const double pause_s = 20.0;
  // The largest position error 4-14 s after the pause's start, beyond the one before it.
  const auto error_after_pause_m = [&](const OdometryConfig& config, bool pause) {
    LidarInertialOdometry odometry(config);
    const Replayed run = replay(r, odometry, [&](std::variant<ImuSample, LidarScan>& e) {
      LidarScan* scan = std::get_if<LidarScan>(&e);
      const double t = scan == nullptr ? 0.0 : r.seconds(scan->utime_us);
      if (pause && t > pause_s && t < pause_s + 4.0) {
        return false;
      }
      if (pause && t > pause_s - 0.1 && t <= pause_s) {
        for (LidarPoint& p : scan->points) {
          p.position_m.y() += 0.6f;
        }
      }
      return true;
    });
    Eigen::Vector3d before = Eigen::Vector3d::Zero();
    double worst = 0.0;
    for (const OdometryEstimate& e : run.estimates) {
      const double t = r.seconds(e.utime_us);
      const Eigen::Vector3d error = run.position_error(r, e);
      if (t < pause_s - 0.2) {
        before = error;
      } else if (t > pause_s + 4.0 && t < pause_s + 14.0) {
        worst = std::max(worst, (error - before).norm());
      }
    }
    return worst;
  };
  OdometryConfig config = config_for(r, false);
  EXPECT_LT(error_after_pause_m(config, true), 0.7);  // 0.57
  config.second_guess_window_s = 0.0;                 // the last two sweeps' velocity only
  EXPECT_GT(error_after_pause_m(config, true), 5.0);
}

// Without an IMU, a pause of 4 s after which the vehicle is 3.6 m higher than before (every
// later sweep's points 3.6 m lower in the body frame: it drove up a ramp, say), which no
// velocity before the pause predicts. The level search keeps the predicted height, and
// registration from there does not reach the ground; each start's height is searched, so
// the sweeps after the pause are placed 3.6 m up. (Searched within 1 cm only, they were
// placed 1.0 m up.) Measured against the same drive without the pause: its height drifts
// 0.31-0.34 m from 20 to 40 s by itself, LiDAR-only, so a fixed bound measured that drift
// (the search's first answer is 0.08 m off).
TEST(Odometry, LidarOnlySearchAfterAPauseFindsTheHeight) {
  const Recording& r = campus_drive();
  // The largest error, from 24 to 40 s, of the climb the estimate shows since 20 s.
  const auto climb_error_m = [&](const OdometryConfig& config, double climb_m) {
    LidarInertialOdometry odometry(config);
    const Replayed run = replay(r, odometry, [&](std::variant<ImuSample, LidarScan>& e) {
      LidarScan* scan = std::get_if<LidarScan>(&e);
      const double t = scan == nullptr ? 0.0 : r.seconds(scan->utime_us);
      if (climb_m > 0.0 && t > 20.0 && t < 24.0) {
        return false;
      }
      if (t >= 24.0) {
        for (LidarPoint& p : scan->points) {
          p.position_m.z() -= static_cast<float>(climb_m);
        }
      }
      return true;
    });
    double before = 0.0, worst = 0.0;
    for (const OdometryEstimate& e : run.estimates) {
      const double t = r.seconds(e.utime_us);
      const double height_error = run.position_error(r, e).z();
      if (t <= 20.0) {
        before = height_error;
      } else if (t >= 24.0 && t < 40.0) {
        worst = std::max(worst, std::abs(height_error - before - climb_m));
      }
    }
    return worst;
  };
  OdometryConfig config = config_for(r, false);
  const double drift_m = climb_error_m(config, 0.0);
  EXPECT_LT(climb_error_m(config, 3.6), drift_m + 0.1);
  config.search_max_z_m = 0.01;
  EXPECT_GT(climb_error_m(config, 3.6), drift_m + 0.6);
}

// Without an IMU, a Mid-360 (no ring below -7 degrees) pauses for 5 s: the first sweep
// after the pause is placed by the search, and that answer is settled with the normal
// kernel (search_settle_after_s). Where settling moves it much (after the pauses from 35
// and 40 s), it fits at least as many points and its roll and pitch are nearer the truth:
// 0.635 against 0.652 and 0.049 against 0.111 degrees. (From 15, 20, 25, 27, 30, 33, 47
// and 50 s it changed nothing, from 45 and 55 s under 0.002 degrees either way, and after
// the pause from 38 s the search itself was refused: a restart. Measured with sweeps that
// fit worse deskewed again, poor_fit_deskew_passes; before, the pauses from 27 and 47 s
// showed it, and before back faces were refused those from 20 and 33 s.) What
// that gains shows where the sweep shares little with the local map, 36 m on at 7 m/s:
// the full sessions of bench_odometry --timing irregular, docs/odometry.md. The planes
// seen edge-on are cut at 0.1, as when this was first measured. By default the sweep after
// the pause is then registered again with its own twist (own_twist_after_gap), from the
// answer, settled or not, so settling is measured without that step. With it (and its tight
// prior on the vertical velocity and the roll and pitch rates) the tilt after the pause is
// 0.367 and 0.082 degrees (0.367 and 0.066 unsettled): it must stay below the unsettled
// answer's without it. (With the correction's prior as loose on them as on the forward
// speed: 0.196 and 0.275, the pitch rate weakly seen here.)
TEST(Odometry, LidarOnlyAfterAPauseTheSearchsAnswerIsSettled) {
  static const Recording r = record("campus", {}, "mid360");
  struct AfterThePause {
    double tilt_error_deg = 0.0, inlier_ratio = 0.0;
  };
  const auto drive = [&](double pause_start_s, double settle_after_s, bool own_twist = false) {
    OdometryConfig config = config_for(r, false);
    config.grazing_ring_spacings_without_imu = 0.0;
    config.search_settle_after_s = settle_after_s;
    config.own_twist_after_gap = own_twist;
    LidarInertialOdometry odometry(config);
    const double pause_end_s = pause_start_s + 5.0;
    const Replayed run = replay_sweeps(r, odometry, [&](double t) {
      return t < pause_start_s || (t > pause_end_s && t < pause_end_s + 0.5);
    });
    for (const OdometryEstimate& e : run.estimates) {
      if (r.seconds(e.utime_us) > pause_end_s) {
        const Eigen::Vector3d rpy_deg = run.rpy_error_rad(r, e) * so3::kRadToDeg;
        return AfterThePause{std::hypot(rpy_deg.x(), rpy_deg.y()), e.inlier_ratio};
      }
    }
    ADD_FAILURE() << "no sweep after the pause from " << pause_start_s << " s";
    return AfterThePause{};
  };
  for (const double pause_start_s : {35.0, 40.0}) {
    const AfterThePause settled = drive(pause_start_s, 1.0);
    const AfterThePause unsettled = drive(pause_start_s, 1e9);
    EXPECT_GE(settled.inlier_ratio, unsettled.inlier_ratio) << "pause from " << pause_start_s;
    EXPECT_LT(settled.tilt_error_deg, unsettled.tilt_error_deg) << "pause from " << pause_start_s;
    const AfterThePause by_default =
        drive(pause_start_s, OdometryConfig{}.search_settle_after_s, true);
    EXPECT_LT(by_default.tilt_error_deg, unsettled.tilt_error_deg)
        << "pause from " << pause_start_s;
  }
}

// Without an IMU a sweep after a pause is deskewed with the twist of before it, and the
// velocity registration then measures is the pause's average: where the vehicle braked or
// sped up in the pause, both are off by part of the change. Registered with the correction
// to its twist that its own points show (own_twist_after_gap), the sweep after the pause
// has the speed it drove at. The pause: the 3 s of the drive's first minute in which the
// speed changes most (from 59.5 s, by 3.15 m/s; after it the speed is 0.40 m/s off, and
// 1.61 m/s without the correction).
TEST(Odometry, LidarOnlyAfterAPauseTheSweepsOwnTwistIsMeasured) {
  const Recording& r = campus_drive();
  const auto true_speed_mps = [&](double t_s) {
    const double t = r.config.start_utime * 1e-6 + t_s;
    return (r.ground_truth.at(t + 0.05, 0.5)->translation() -
            r.ground_truth.at(t - 0.05, 0.5)->translation())
               .norm() /
           0.1;
  };
  const double pause_s = 3.0;
  double pause_start_s = 0.0;
  double change_mps = 0.0;
  for (double t = 15.0; t < 60.0; t += 0.5) {
    const double change = std::abs(true_speed_mps(t + pause_s) - true_speed_mps(t));
    if (change > change_mps) {
      change_mps = change;
      pause_start_s = t;
    }
  }
  ASSERT_GT(change_mps, 1.5);
  const double pause_end_s = pause_start_s + pause_s;
  const auto speed_error_after_pause_mps = [&](bool own_twist) {
    OdometryConfig config = config_for(r, false);
    config.own_twist_after_gap = own_twist;
    LidarInertialOdometry odometry(config);
    const Replayed run = replay_sweeps(r, odometry, [&](double t) {
      return t < pause_start_s || (t > pause_end_s && t < pause_end_s + 1.0);
    });
    EXPECT_EQ(odometry.counters().own_twists_after_gaps, own_twist ? 1 : 0);
    for (const OdometryEstimate& e : run.estimates) {
      const double t = r.seconds(e.utime_us);
      if (t > pause_end_s) {
        return std::abs(e.velocity_odom.norm() - true_speed_mps(t));
      }
    }
    ADD_FAILURE() << "no sweep after the pause from " << pause_start_s << " s";
    return 0.0;
  };
  EXPECT_LT(speed_error_after_pause_mps(true), 0.25 * change_mps) << change_mps;
  EXPECT_GT(speed_error_after_pause_mps(false), 0.25 * change_mps) << change_mps;
}

// Without an IMU the constant-velocity model misses a quick swerve: another town's campus A
// comes back through its start with a 6.5-degree kink taken at 24 deg/s, the sweeps through
// it registered from the prediction settled 1.6 degrees behind and 3 beyond, fitting
// 0.14-0.27 m where the drive fits 0.03 m, the local map took them in and the drive kept a
// 2.9-degree yaw error (bench_odometry --world-seed 2 --lidar mid360 --imu off: 1.1 m ATE).
// Here the heading jumps by 15 degrees at 20 s (every later sweep turned on the vehicle):
// registered from the prediction the first sweep after it stays 15 degrees off, and the
// drive keeps that for good; searched for, it is found, and after a second of ringing (the
// jump taken for a rate) the estimate leads the truth by the jump alone. (A jump of 10
// degrees, as when this was written, registration now finds by itself within 2 s: with
// back faces refused, registration.reject_back_faces, the sweep turned by 10 degrees is no
// longer held by the far sides of walls.)
TEST(Odometry, LidarOnlyASweepTheMotionModelMissedIsSearchedFor) {
  const Recording& r = campus_drive();
  const double jump_deg = 15.0;
  struct YawError {
    double first_deg = -1.0;    // the first sweep after the jump (-1: none)
    double after_2s_deg = 0.0;  // the worst from 2 s after it
  };
  const auto yaw_error = [&](double poor_fit_factor) {
    OdometryConfig config = config_for(r, false);
    config.poor_fit_factor = poor_fit_factor;
    LidarInertialOdometry odometry(config);
    const Eigen::Matrix3f R_turned =
        Eigen::AngleAxisf(static_cast<float>(-jump_deg / so3::kRadToDeg), Eigen::Vector3f::UnitZ())
            .toRotationMatrix();
    const Replayed run = replay(r, odometry, [&](std::variant<ImuSample, LidarScan>& e) {
      LidarScan* scan = std::get_if<LidarScan>(&e);
      if (scan && r.seconds(scan->utime_us) > 20.0) {
        for (LidarPoint& p : scan->points) {
          p.position_m = R_turned * p.position_m;
        }
      }
      return scan == nullptr || r.seconds(scan->utime_us) < 23.0;
    });
    YawError out;
    for (const OdometryEstimate& e : run.estimates) {
      const double t_s = r.seconds(e.utime_us);
      const double error_deg = std::abs(run.rpy_error_rad(r, e).z() * so3::kRadToDeg - jump_deg);
      if (t_s > 20.15 && out.first_deg < 0.0) {
        out.first_deg = error_deg;
      }
      if (t_s > 22.15) {
        out.after_2s_deg = std::max(out.after_2s_deg, error_deg);
      }
    }
    EXPECT_GE(out.first_deg, 0.0) << "no sweep after the jump";
    return out;
  };
  const YawError searched = yaw_error(OdometryConfig{}.poor_fit_factor);
  EXPECT_LT(searched.first_deg, 0.5);     // 0.04
  EXPECT_LT(searched.after_2s_deg, 0.5);  // 0.17
  const YawError registered = yaw_error(0.0);
  EXPECT_GT(registered.first_deg, 5.0);     // 15.2
  EXPECT_GT(registered.after_2s_deg, 5.0);  // 15.3
}

// A LiDAR-only drive of r, its config changed by edit: the heading's error against the
// truth (the sweeps more than a degree off and the largest), the largest roll and pitch error
// (the norm of the two), the ATE, and the sweeps that fit worse deskewed again.
struct LidarOnlyDrive {
  int yaw_beyond_1deg = 0;
  double worst_yaw_deg = 0.0;
  double worst_tilt_deg = 0.0;
  double ate_m = 0.0;
  int64_t deskewed = 0;
};

template <class Edit>
LidarOnlyDrive drive_lidar_only(const Recording& r, Edit edit) {
  OdometryConfig config = config_for(r, false);
  edit(config);
  LidarInertialOdometry odometry(config);
  const Replayed run = replay(r, odometry);
  LidarOnlyDrive out;
  for (const OdometryEstimate& e : run.estimates) {
    const Eigen::Vector3d error_rad = run.rpy_error_rad(r, e);
    const double error_deg = std::abs(error_rad.z()) * so3::kRadToDeg;
    out.yaw_beyond_1deg += error_deg > 1.0 ? 1 : 0;
    out.worst_yaw_deg = std::max(out.worst_yaw_deg, error_deg);
    out.worst_tilt_deg = std::max(out.worst_tilt_deg, error_rad.head<2>().norm() * so3::kRadToDeg);
  }
  out.ate_m = run.metrics(r).ate_position_rmse_m;
  out.deskewed = odometry.counters().poor_fits_deskewed;
  return out;
}

// Without an IMU a sweep is deskewed with the previous sweep's twist. Where a turn ends
// within it, its points are warped by the turn it no longer makes, and registered from the
// prediction it settled degrees short of the truth; the sweeps after it rang about the truth
// (Mid-360 campus A: -2.5 to +1.2 degrees for a second) and the local map took them in.
// Deskewed again along the motion registration measured (poor_fit_deskew_passes), the
// sweep fits where it is.
TEST(Odometry, LidarOnlyASweepWarpedByATurnsEndIsDeskewedAgain) {
  const Recording& r = campus_drive();
  const auto drive = [&](int passes) {
    return drive_lidar_only(r, [&](OdometryConfig& c) { c.poor_fit_deskew_passes = passes; });
  };
  const LidarOnlyDrive deskewed = drive(OdometryConfig{}.poor_fit_deskew_passes);
  EXPECT_LE(deskewed.yaw_beyond_1deg, 3);  // 1
  EXPECT_LT(deskewed.worst_yaw_deg, 1.6);  // 1.23
  EXPECT_GT(deskewed.deskewed, 0);         // 12
  const LidarOnlyDrive once = drive(0);
  EXPECT_GE(once.yaw_beyond_1deg, 8);  // 18
  EXPECT_GT(once.worst_yaw_deg, 2.0);  // 2.20
  EXPECT_EQ(once.deskewed, 0);
}

// A VLP-16 drives off from the start of bench_odometry's campus D (its first waypoints).
// Matched, the ceilings far above it (undersides of canopies and tree crowns, which its map
// holds as one ring of successive sweeps) tilted the estimate nose up while it gathered
// speed, and the map kept that tilt; left out beyond 14.3 m
// (far_ceilings_left_out_without_imu), the ground holds it.
TEST(Odometry, LidarOnlyFarCeilingsDoNotTiltARingLidar) {
  const Recording r = record_session_start(1, "D", 3, "vlp16");
  const auto drive = [&](bool left_out) {
    return drive_lidar_only(
        r, [&](OdometryConfig& c) { c.far_ceilings_left_out_without_imu = left_out; });
  };
  const LidarOnlyDrive left_out = drive(true);
  const LidarOnlyDrive matched = drive(false);
  EXPECT_LT(left_out.worst_tilt_deg, 0.5);  // 0.32
  EXPECT_LT(left_out.ate_m, 0.03);          // 0.015
  EXPECT_GT(matched.worst_tilt_deg, 1.2);   // 2.06
  EXPECT_GT(matched.ate_m, 0.035);          // 0.047
}

// Only a pass that takes poor_fit_deskew_min_gain of the residual is kept. A VLP-16 that
// creeps off open ground (bench_odometry's campus C, its first 140 m, LiDAR-only) fits
// 180-360 points on planes at a residual of a few centimetres, and passes along twists of
// noise fit it a little better: kept, they turned the drive up to 38 degrees off. (The
// start turns 14 degrees with them left too: the start's own, docs/odometry.md.) With the
// far ceilings left out (far_ceilings_left_out_without_imu) this start holds with any pass
// kept (0.034 m ATE, 0.40 degrees): the test matches them, as when the gain rule was made
// for it.
TEST(Odometry, LidarOnlyAPassThatFitsLittleBetterIsNotKept) {
  const Recording r = record_session_start(1, "C", 3, "vlp16");
  const auto drive = [&](double min_gain) {
    return drive_lidar_only(r, [&](OdometryConfig& c) {
      c.poor_fit_deskew_min_gain = min_gain;
      c.far_ceilings_left_out_without_imu = false;
    });
  };
  const LidarOnlyDrive gain_rule = drive(OdometryConfig{}.poor_fit_deskew_min_gain);
  EXPECT_LT(gain_rule.ate_m, 2.5);           // 1.23
  EXPECT_LT(gain_rule.worst_yaw_deg, 20.0);  // 14.1
  const LidarOnlyDrive any_gain = drive(0.0);
  EXPECT_GT(any_gain.ate_m, 4.0);                    // 6.18
  EXPECT_GT(any_gain.worst_yaw_deg, 25.0);           // 37.7
  EXPECT_GT(any_gain.deskewed, gain_rule.deskewed);  // 4 against 1
}

// A VLP-16 that starts in the open (bench_odometry's campus A of world seed 2): standing,
// its sweeps fit 1-8 planes, and it creeps off at 0.35 m/s on a smooth road, which to the
// IMU looks like standing. With the zero-velocity update allowed up to 0.3 m/s of believed
// speed it held the creep at zero, and the sweeps after it, fitting few planes, kept the
// estimate a quarter behind the motion (20 m off after 16 s; 8.5 m ATE over the session).
TEST(Odometry, ACreepingStartIsNotTakenForAStandstill) {
  const Recording r = record_session_start(2, "A", 3, "vlp16");
  const auto ate_m = [&](double standstill_max_speed_mps) {
    OdometryConfig config = config_for(r);
    config.standstill_max_speed_mps = standstill_max_speed_mps;
    LidarInertialOdometry odometry(config);
    return replay(r, odometry).metrics(r).ate_position_rmse_m;
  };
  EXPECT_LT(ate_m(OdometryConfig{}.standstill_max_speed_mps), 0.1);
  EXPECT_GT(ate_m(0.3), 1.0);
}

// With the IMU, pauses of 4 s every 15 s (a LiDAR driver that stalls, a log filtered by
// rate, or a blocked LiDAR whose sweeps have 20 points) while the accelerometer reads
// 0.15 m/s^2 beyond its bias (a knock, heat): over a pause the prediction is then off by
// more than the filter's covariance says, 1.2 m here. The first sweep registered after it
// is placed by the search within long_gap_search_m and does not update the biases: the
// registered estimates stay within 0.1 m and the biases are found as in the drive that
// sees every sweep. Registered from the prediction as any other sweep (long_gap_s beyond the
// pauses), it is 1.75 m off.
TEST(Odometry, WithTheImuPausesOfSecondsAreBridged) {
  const Recording& r = campus_drive();
  struct Outcome {
    double ate_m = 0.0, accel_bias_error = 0.0;
    int64_t searched = 0, lost = 0;
  };
  const auto drive = [&](const OdometryConfig& config, bool blocked) {
    LidarInertialOdometry odometry(config);
    const Replayed run = replay(r, odometry, [&](std::variant<ImuSample, LidarScan>& e) {
      const int64_t utime_us = std::visit([](const auto& m) { return m.utime_us; }, e);
      if (std::fmod(r.seconds(utime_us), 15.0) < 11.0) {
        return true;
      }
      if (ImuSample* imu = std::get_if<ImuSample>(&e)) {
        imu->accel_mps2.x() += 0.15;
        return true;
      }
      std::get<LidarScan>(e).points.resize(20);
      return blocked;
    });
    // (Within a blocked stretch the pose is the IMU's alone, off by up to 1.2 m.)
    Replayed registered;
    std::copy_if(run.estimates.begin(), run.estimates.end(),
                 std::back_inserter(registered.estimates),
                 [](const OdometryEstimate& e) { return e.registered; });
    const OdometryCounters& c = odometry.counters();
    return Outcome{registered.metrics(r).ate_position_rmse_m,
                   (odometry.state().ba - r.accel_bias).norm(), c.searched_scans, c.lost_scans};
  };
  OdometryConfig config = config_for(r);
  for (const bool blocked : {false, true}) {
    const Outcome o = drive(config, blocked);
    EXPECT_LT(o.ate_m, 0.1) << "blocked " << blocked;
    EXPECT_LT(o.accel_bias_error, 0.03) << "blocked " << blocked;
    EXPECT_GE(o.searched, 3) << "blocked " << blocked;
    EXPECT_EQ(o.lost, 0) << "blocked " << blocked;
  }
  config.long_gap_s = 1e6;
  EXPECT_GT(drive(config, false).ate_m, 0.5);
}

// After a pause, a sweep that fits no part of the local map (its points scaled threefold:
// a scene that exists nowhere) is not forced into it: the estimate says it is lost and
// why, the local map restarts, and the sweeps after it track again.
TEST(Odometry, ASweepThatFitsNothingRestartsTheLocalMapAndSaysSo) {
  const Recording& r = campus_drive();
  LidarInertialOdometry odometry(config_for(r, false));
  bool scaled = false;
  const Replayed run = replay(r, odometry, [&](std::variant<ImuSample, LidarScan>& e) {
    LidarScan* scan = std::get_if<LidarScan>(&e);
    const double t = scan == nullptr ? 0.0 : r.seconds(scan->utime_us);
    if (t > 20.0 && t < 22.0) {
      return false;  // a 2 s pause
    }
    if (t >= 22.0 && !scaled) {
      scaled = true;
      for (LidarPoint& p : scan->points) {
        p.position_m *= 3.0f;
      }
    }
    return true;
  });
  EXPECT_GE(odometry.counters().map_restarts, 1);
  const OdometryEstimate* lost = run.first_lost();
  ASSERT_NE(lost, nullptr);
  EXPECT_NEAR(r.seconds(lost->utime_us), 22.1, 0.2) << lost->lost_reason;
  EXPECT_NE(lost->lost_reason.find("the local map restarts"), std::string::npos);
  run.expect_moves_as_truth(r, 30.0, 60.0);
  for (const OdometryEstimate& e : run.estimates) {
    ASSERT_TRUE(e.T_odom_body.matrix().allFinite());
  }
}

// Without an IMU, a pause of 4 s through a corner after which the first sweep fits nothing
// (its points scaled threefold, a scene that exists nowhere): the local map restarts at the
// constant-velocity prediction, which carried the vehicle straight on. The local map of
// before is kept; a second later the new one is found in it and the estimate moves back
// onto it, as accurate as a drive without the pause. Without (reanchor_attempts 0) the
// prediction's error stays: 98 m, measured when this was written. With the IMU as well.
TEST(Odometry, AfterARestartTheLocalMapIsFoundInTheOneBefore) {
  const Recording& r = campus_drive();
  const double pause_s = 30.0;  // 30-34 s: the vehicle turns 79 degrees
  struct Outcome {
    double error_m = 0.0;  // the largest position error 6-20 s after the pause's start,
                           // beyond the one before it
    int64_t restarts = 0;
    int64_t reanchors = 0;
    std::string reanchored;
  };
  const auto drive = [&](const OdometryConfig& config, bool pause) {
    LidarInertialOdometry odometry(config);
    bool scaled = false;
    const Replayed run = replay(r, odometry, [&](std::variant<ImuSample, LidarScan>& e) {
      LidarScan* scan = std::get_if<LidarScan>(&e);
      const double t = scan == nullptr ? 0.0 : r.seconds(scan->utime_us);
      if (pause && t > pause_s && t < pause_s + 4.0) {
        return false;
      }
      if (pause && t >= pause_s + 4.0 && !scaled) {
        scaled = true;
        for (LidarPoint& p : scan->points) {
          p.position_m *= 3.0f;
        }
      }
      return true;
    });
    Outcome o;
    o.restarts = odometry.counters().map_restarts;
    o.reanchors = odometry.counters().reanchors;
    Eigen::Vector3d before = Eigen::Vector3d::Zero();
    for (const OdometryEstimate& e : run.estimates) {
      const double t = r.seconds(e.utime_us);
      const Eigen::Vector3d error = run.position_error(r, e);
      if (t < pause_s) {
        before = error;
      } else if (t > pause_s + 6.0 && t < pause_s + 20.0) {
        o.error_m = std::max(o.error_m, (error - before).norm());
      }
      if (!e.reanchored.empty()) {
        o.reanchored = e.reanchored;
      }
    }
    return o;
  };
  OdometryConfig config = config_for(r, false);
  const Outcome unpaused = drive(config, false);
  EXPECT_EQ(unpaused.restarts, 0);
  const Outcome kept = drive(config, true);
  EXPECT_GE(kept.restarts, 1);
  EXPECT_EQ(kept.reanchors, 1);
  EXPECT_NE(kept.reanchored.find("found in the one before it"), std::string::npos)
      << kept.reanchored;
  EXPECT_LT(kept.error_m, unpaused.error_m + 0.1) << kept.reanchored;
  config.reanchor_attempts = 0;
  const Outcome not_kept = drive(config, true);
  EXPECT_EQ(not_kept.reanchors, 0);
  EXPECT_GT(not_kept.error_m, 5.0);
  // With the IMU the restart is at the IMU's prediction, close already; the move onto the
  // old map turns velocity and gravity with it, and the drive goes on as without the pause.
  const OdometryConfig with_imu = config_for(r, true);
  const Outcome imu_kept = drive(with_imu, true);
  EXPECT_EQ(imu_kept.reanchors, 1);
  EXPECT_LT(imu_kept.error_m, drive(with_imu, false).error_m + 0.1) << imu_kept.reanchored;
}

// Without an IMU, the sweep after a pause of 2 s is placed nowhere (every search is refused
// here) and begins a new local map at the prediction. In that map the pose is exact, so
// the next sweep, 0.1 s later, is registered to it as any well predicted sweep, not
// searched and refused again: one restart, and the drive after it moves as the truth does.
// With the restart's spread kept, every later sweep was searched and restarted the map.
TEST(Odometry, AfterARestartTheNextSweepIsRegisteredToTheNewLocalMap) {
  const Recording& r = campus_drive();
  OdometryConfig config = config_for(r, false);
  config.search_min_inlier_ratio = config.search_confirmed_inlier_ratio = 1.01;
  LidarInertialOdometry odometry(config);
  const Replayed run = replay_sweeps(r, odometry, [](double t) { return t <= 20.0 || t >= 22.0; });
  EXPECT_EQ(odometry.counters().map_restarts, 1);
  EXPECT_EQ(odometry.counters().searched_scans, 1);
  run.expect_moves_as_truth(r, 23.0, 45.0);
}

// Without an IMU, the sweep after a pause of 2 s is placed nowhere (every search is refused
// here by floors no answer reaches) and begins a new local map; 0.2 s later a pause of 3 s.
// The sweep after it is searched in a local map of three sweeps: its starts agree on an
// answer, and in a map that young the young map's floor (young_map_inserts) takes it. The
// move across the pause is then 0.31 m off the truth's, measured when this was written;
// without that floor the local map restarted again, at the prediction, 1.42 m off.
TEST(Odometry, LidarOnlyAYoungLocalMapTakesAConfirmedAnswerThatFitsFewerPoints) {
  const Recording& r = campus_drive();
  struct Outcome {
    int64_t restarts = 0;
    int64_t young_accepted = 0;
    double error_m = -1.0;  // of the move across the second pause, against the truth's
  };
  const auto drive = [&](int young_map_inserts) {
    OdometryConfig config = config_for(r, false);
    config.search_min_inlier_ratio = config.search_confirmed_inlier_ratio = 1.01;
    config.restart_at_answer_starts = 0;
    config.young_map_inserts = young_map_inserts;
    LidarInertialOdometry odometry(config);
    const Replayed run = replay_sweeps(
        r, odometry, [](double t) { return (t <= 20.0 || t >= 22.0) && (t <= 22.2 || t >= 25.2); });
    Outcome o;
    o.restarts = odometry.counters().map_restarts;
    o.young_accepted = odometry.counters().young_map_searches_accepted;
    const auto after =
        std::find_if(run.estimates.begin(), run.estimates.end(),
                     [&](const OdometryEstimate& e) { return r.seconds(e.utime_us) > 25.0; });
    if (after != run.estimates.begin() && after != run.estimates.end()) {
      const OdometryEstimate& before = *std::prev(after);
      const Eigen::Vector3d moved =
          (before.T_odom_body.inverse() * after->T_odom_body).translation();
      const Eigen::Vector3d moved_truth =
          (r.ground_truth.at(before.utime_us * 1e-6, 0.5)->inverse() *
           *r.ground_truth.at(after->utime_us * 1e-6, 0.5))
              .translation();
      o.error_m = (moved - moved_truth).norm();
    }
    return o;
  };
  const Outcome young = drive(10);
  EXPECT_EQ(young.restarts, 1);
  EXPECT_EQ(young.young_accepted, 1);
  EXPECT_GE(young.error_m, 0.0) << "no sweeps around the second pause";
  EXPECT_LT(young.error_m, 0.5);
  const Outcome without = drive(0);
  EXPECT_EQ(without.restarts, 2);
  EXPECT_EQ(without.young_accepted, 0);
  EXPECT_GT(without.error_m, 1.0);
}

// Without an IMU, a pause of 4 s through a corner, and every search refused (none is
// confirmed here, the re-anchoring's neither): the local map restarts. At the
// constant-velocity prediction, which carried the vehicle straight on, the drive after the
// pause is 74 m off (measured when this was written); at the answer that two of the
// search's starts agree on, the first sweep is 0.11 m off and the drive in the new local
// map within 0.95 m over the next 10 s. The restart's reason says where it restarted.
TEST(Odometry, LidarOnlyARefusedSearchAfterAPauseRestartsAtItsAnswer) {
  const Recording& r = campus_drive();
  const double pause_s = 30.0;  // 30-34 s: the vehicle turns 79 degrees
  struct Outcome {
    // Position errors beyond the one before the pause: at the first sweep after it, and
    // the largest up to 14 s after the pause's start.
    double first_error_m = -1.0, error_m = 0.0;
    std::string lost_reason;
  };
  const auto drive = [&](int restart_at_answer_starts) {
    OdometryConfig config = config_for(r, false);
    config.search_min_inlier_ratio = 1.01;
    config.search_confirming_starts = 1000;
    config.restart_at_answer_starts = restart_at_answer_starts;
    LidarInertialOdometry odometry(config);
    const Replayed run =
        replay_sweeps(r, odometry, [&](double t) { return t <= pause_s || t >= pause_s + 4.0; });
    Outcome o;
    Eigen::Vector3d before = Eigen::Vector3d::Zero();
    for (const OdometryEstimate& e : run.estimates) {
      const double t = r.seconds(e.utime_us);
      const Eigen::Vector3d error = run.position_error(r, e);
      if (t <= pause_s + 1.0) {
        before = error;
      } else if (t < pause_s + 14.0) {
        o.error_m = std::max(o.error_m, (error - before).norm());
        if (o.first_error_m < 0.0) {
          o.first_error_m = (error - before).norm();
          o.lost_reason = e.lost_reason;
        }
      }
    }
    return o;
  };
  const Outcome at_answer = drive(2);
  EXPECT_NE(at_answer.lost_reason.find("restarts at the search's answer"), std::string::npos)
      << at_answer.lost_reason;
  EXPECT_GE(at_answer.first_error_m, 0.0) << "no sweep after the pause";
  EXPECT_LT(at_answer.first_error_m, 0.3);
  EXPECT_LT(at_answer.error_m, 1.5);
  const Outcome at_prediction = drive(0);
  EXPECT_NE(at_prediction.lost_reason.find("restarts at the predicted pose"), std::string::npos)
      << at_prediction.lost_reason;
  EXPECT_GT(at_prediction.first_error_m, 2.0);
  EXPECT_GT(at_prediction.error_m, 10.0);
}

// A shove no vehicle makes (1000 m/s^2 for 0.1 s, far past what the LiDAR can outweigh):
// the speed check resets to the previous pose and the velocity from before the shove, in
// the same local map, and the drive goes on. (The previous sweep's velocity, which the
// reset used to restore, is the shove's own.)
TEST(Odometry, AnImplausibleSpeedResetsToTheLastTrustedStateInTheSameMap) {
  const Recording& r = campus_drive();
  LidarInertialOdometry odometry(config_for(r, true));
  const Replayed run = replay_with_imu_fault(r, odometry, [](double t, ImuSample& imu) {
    if (t > 30.0 && t < 30.1) {
      imu.accel_mps2.x() += 1000.0;
    }
  });
  EXPECT_GE(odometry.counters().health_resets, 1);
  EXPECT_EQ(odometry.counters().map_restarts, 0);
  const OdometryEstimate* lost = run.first_lost();
  ASSERT_NE(lost, nullptr);
  EXPECT_NEAR(r.seconds(lost->utime_us), 30.1, 0.15) << lost->lost_reason;
  EXPECT_NE(lost->lost_reason.find("last trusted pose and velocity"), std::string::npos)
      << lost->lost_reason;
  run.expect_moves_as_truth(r, 30.0, 60.0);
  EXPECT_LT(run.metrics(r).ate_position_rmse_m, 0.1);
}

// An IMU that goes wrong for seconds: the accelerometer off by 15 m/s^2 for 3 s, then the
// gyro by 0.2 rad/s (11 deg/s) for 3 s. The LiDAR contradicts the prediction, outweighs
// it, and the drive holds to centimetres without a reset. (Before: the filter's velocity,
// certain to 4 mm/s, took no correction from the LiDAR, and the estimate ran away at
// 40 m/s, then reset 321 times to the end of the drive, 47 m ATE; the gyro fault alone
// drifted 31 m in silence.) The clean drive contradicts it nowhere.
TEST(Odometry, AFaultyImuIsOutweighedByTheLidar) {
  const Recording& r = campus_drive();
  LidarInertialOdometry odometry(config_for(r, true));
  const Replayed run = replay_with_imu_fault(r, odometry, [](double t, ImuSample& imu) {
    if (t > 30.0 && t < 33.0) {
      imu.accel_mps2.x() += 15.0;
    }
    if (t > 45.0 && t < 48.0) {
      imu.gyro_rps.z() += 0.2;
    }
  });
  EXPECT_EQ(odometry.counters().health_resets, 0);
  EXPECT_EQ(odometry.counters().lost_scans, 0);
  EXPECT_GE(odometry.counters().imu_disagreements, 2);
  const auto said = std::find_if(run.estimates.begin(), run.estimates.end(),
                                 [](const auto& e) { return !e.imu_disagreement.empty(); });
  ASSERT_NE(said, run.estimates.end());
  EXPECT_NEAR(r.seconds(said->utime_us), 30.2, 0.15) << said->imu_disagreement;
  EXPECT_NE(said->imu_disagreement.find("contradicts the IMU"), std::string::npos);
  run.expect_moves_as_truth(r, 25.0, 60.0);
  EXPECT_LT(run.metrics(r).ate_position_rmse_m, 0.1);
  EXPECT_LT(run.metrics(r).rpe_translation_percent, 0.5);
}

// A gyro off by radians per second smears each sweep by 6-29 degrees within itself when it
// is deskewed: no pose fits it, registration stays by the wrong prediction with a small
// innovation, and the estimate went 19 m (1 rad/s for 1 s) and 34 m (5 rad/s for 0.2 s) off
// in silence. The sweep deskewed and predicted with the LiDAR's own last twist fits twice as
// many points: it is taken, and said, and the drive holds.
TEST(Odometry, AGyroFaultIsFoundByTheLidarsOwnMotion) {
  const Recording& r = campus_drive();
  LidarInertialOdometry odometry(config_for(r, true));
  const Replayed run = replay_with_imu_fault(r, odometry, [](double t, ImuSample& imu) {
    if (t > 30.0 && t < 31.0) {
      imu.gyro_rps.z() += 1.0;
    }
    if (t > 50.0 && t < 50.2) {
      imu.gyro_rps.z() -= 5.0;
    }
  });
  EXPECT_EQ(odometry.counters().health_resets, 0);
  EXPECT_EQ(odometry.counters().lost_scans, 0);
  for (const double fault_s : {30.0, 50.0}) {
    const auto said = std::find_if(run.estimates.begin(), run.estimates.end(), [&](const auto& e) {
      return r.seconds(e.utime_us) > fault_s && !e.imu_disagreement.empty();
    });
    ASSERT_NE(said, run.estimates.end());
    EXPECT_NEAR(r.seconds(said->utime_us), fault_s + 0.1, 0.05) << said->imu_disagreement;
    EXPECT_NE(said->imu_disagreement.find("the LiDAR's own motion"), std::string::npos)
        << said->imu_disagreement;
  }
  run.expect_moves_as_truth(r, 25.0, 60.0);
  EXPECT_LT(run.metrics(r).ate_position_rmse_m, 0.1);
}

// A gyro that stays wrong by 1 rad/s: the LiDAR's own motion carries the drive until the
// next corner, where it lags as the IMU is off. Before, the estimate then drifted at 10 m/s
// in silence (104 m): the sweeps still matched 50-100 planes, above the weak-fit floor, but
// put only 13-16 % of their points on the map. With back faces refused they went on
// fitting the local map turned by 19 degrees at the corner (60 %: 27 m in silence). Now
// the LiDAR overruling the IMU on most sweeps for 5 s says it is lost (and goes on with the
// LiDAR's own motion); without that check (and back faces matched, where the fit
// collapses) the weak fit does, and restarts the local map. Since back faces near their
// plane are matched (registration.back_face_min_offset_m) this drive's fit collapses
// again: with the defaults the weak fit says it first, and with the weak fit off nothing
// said it (the LiDAR overruled the IMU on fewer than 80 % of the sweeps; not traced). The
// lasting-fault check is driven by the smaller step of the next test, where the fit holds.
TEST(Odometry, AGyroWrongForGoodIsReportedLost) {
  const Recording& r = campus_drive();
  const auto first_lost = [&](const OdometryConfig& config) {
    LidarInertialOdometry odometry(config);
    const Replayed run = replay_with_gyro_step(r, odometry, 1.0);
    const OdometryEstimate* lost = run.first_lost();
    return lost == nullptr ? std::make_pair(1e9, std::string())
                           : std::make_pair(r.seconds(lost->utime_us), lost->lost_reason);
  };
  OdometryConfig config = config_for(r, true);
  const auto [first_s, first_reason] = first_lost(config);
  EXPECT_LT(first_s, 36.0) << first_reason;
  config.imu_fault_window_s = 0.0;
  config.registration.reject_back_faces = false;
  const auto [weak_s, weak_reason] = first_lost(config);
  EXPECT_LT(weak_s, 36.0) << weak_reason;
  EXPECT_NE(weak_reason.find("weak_fit_inlier_ratio"), std::string::npos) << weak_reason;
  EXPECT_NE(weak_reason.find("the local map restarts"), std::string::npos) << weak_reason;
}

// A gyro that steps by 0.3 rad/s for good, as a bias step would: the LiDAR overrules the
// IMU until the lasting-fault check reports it, and the report reopens the gyro bias's
// covariance, so the next sweeps learn the step (imu_fault_gyro_bias_sigma_rps). While the
// IMU is distrusted the biases are only considered, so with the bias kept it is never
// learned: here 0.89 m ATE against 0.130 m with it learned, and HDL-32E campus A
// (bench_odometry --imu-fault gyro,0.3,30,1000) 196.5 m against 0.050 m.
TEST(Odometry, AGyroStepThatStaysIsLearnedAsItsBias) {
  const Recording& r = campus_drive();
  const auto drive = [&](const OdometryConfig& config) {
    LidarInertialOdometry odometry(config);
    const Replayed run = replay_with_gyro_step(r, odometry, 0.3);
    const OdometryEstimate* lost = run.first_lost();
    EXPECT_NE(lost, nullptr);
    return std::make_tuple(run.metrics(r).ate_position_rmse_m,
                           odometry.state().bg.z() - r.gyro_bias.z(),
                           lost == nullptr ? std::string() : lost->lost_reason);
  };
  OdometryConfig config = config_for(r, true);
  const auto [learned_ate_m, learned_step_rps, reason] = drive(config);
  EXPECT_NE(reason.find("a lasting IMU fault"), std::string::npos) << reason;
  EXPECT_NE(reason.find("the gyro bias is learned again"), std::string::npos) << reason;
  EXPECT_NEAR(learned_step_rps, 0.3, 0.01);
  EXPECT_LT(learned_ate_m, 0.3);  // the clean drive's bound
  config.imu_fault_gyro_bias_sigma_rps = 0.0;
  const auto [kept_ate_m, kept_step_rps, kept_reason] = drive(config);
  EXPECT_LT(kept_step_rps, 0.2);
  EXPECT_GT(kept_ate_m, 0.5);
}

// A LiDAR whose driver for six seconds decodes garbage (points scattered through the air
// above the scene) leaves the IMU to carry the estimate with no plane to check it against: once the
// median sweep over weak_fit_window_s matched fewer than weak_fit_correspondences planes,
// the estimate says it is lost and why, the local map restarts, and the sweeps after the
// fog track again. (The clean drive of the test above never trips it.)
TEST(Odometry, SweepsThatMatchAlmostNothingAreReportedLost) {
  const Recording& r = campus_drive();
  LidarInertialOdometry odometry(config_for(r, true));
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  const Replayed run = replay(r, odometry, [&](std::variant<ImuSample, LidarScan>& e) {
    if (LidarScan* scan = std::get_if<LidarScan>(&e)) {
      const double t = r.seconds(scan->utime_us);
      if (t > 30.0 && t < 36.0) {
        for (LidarPoint& p : scan->points) {
          p.position_m = Eigen::Vector3f(100.0f * unit(rng) - 50.0f, 100.0f * unit(rng) - 50.0f,
                                         20.0f + 20.0f * unit(rng));
        }
      }
    }
    return true;
  });
  const OdometryEstimate* lost = run.first_lost();
  ASSERT_NE(lost, nullptr);
  // The median turns when half the window is garbage.
  EXPECT_NEAR(r.seconds(lost->utime_us), 31.6, 0.4) << lost->lost_reason;
  EXPECT_NE(lost->lost_reason.find("planes of the local map"), std::string::npos)
      << lost->lost_reason;
  EXPECT_GE(odometry.counters().health_resets, 1);
  run.expect_moves_as_truth(r, 40.0, 60.0);
}

// Half a second of IMU lost twice, repeated and reordered samples and sweeps, empty
// and tiny sweeps: the odometry counts them and keeps tracking.
TEST(Odometry, SurvivesGapsDisorderAndEmptySweeps) {
  const Recording& r = campus_drive();
  LidarInertialOdometry odometry(config_for(r));
  int64_t last_imu = 0;
  int sweep = 0;
  std::optional<ImuSample> held;
  const Replayed run = replay(r, odometry, [&](std::variant<ImuSample, LidarScan>& e) {
    if (auto* s = std::get_if<ImuSample>(&e)) {
      const double t = r.seconds(s->utime_us);
      if ((t > 20.0 && t < 20.5) || (t > 35.0 && t < 35.5)) {
        return false;  // IMU gaps
      }
      if (s->utime_us % 1000000 == 0 && last_imu > 0) {
        odometry.add_imu(*s);  // a repeated sample
      }
      last_imu = s->utime_us;
      return true;
    }
    LidarScan& scan = std::get<LidarScan>(e);
    ++sweep;
    if (sweep % 97 == 0) {
      odometry.add_scan(scan);  // the same sweep twice
    }
    if (sweep % 131 == 0) {
      scan.points.clear();  // an empty sweep
    } else if (sweep % 151 == 0) {
      scan.points.resize(20);  // a tiny one
    }
    return true;
  });
  const OdometryCounters& c = odometry.counters();
  EXPECT_GT(c.imu_gaps, 0);
  EXPECT_GT(c.imu_rejected, 0);
  EXPECT_GT(c.scans_out_of_order, 0);
  EXPECT_GE(c.scans_too_small, 3);
  const eval::TrajectoryMetrics m = run.metrics(r);
  EXPECT_LT(m.rpe_translation_percent, 1.5);
  EXPECT_LT(m.ate_position_rmse_m, 0.5);
  for (const OdometryEstimate& e : run.estimates) {
    ASSERT_TRUE(e.T_odom_body.matrix().allFinite());
  }
}

// A pose correction is blended in: the output never jumps, and it arrives.
TEST(Odometry, PoseCorrectionsAreBlendedWithoutJumps) {
  const Recording& r = campus_drive();
  OdometryConfig config = config_for(r);
  LidarInertialOdometry reference(config);
  const Replayed plain = replay(r, reference);
  LidarInertialOdometry odometry(config);
  bool sent = false;
  const Replayed run = replay(r, odometry, [&](std::variant<ImuSample, LidarScan>&) {
    if (!sent && odometry.counters().scans_processed == 300) {
      // The optimizer says: 1 m further east and 2 degrees more yaw than you think.
      const OdometryEstimate& e = plain.estimates[299];
      OdometryCorrection c;
      c.utime_us = e.utime_us;
      c.T_odom_body = se3::make(so3::exp(Eigen::Vector3d(0, 0, 0.035)), Eigen::Vector3d(1, 0, 0)) *
                      e.T_odom_body;
      odometry.add_correction(c);
      sent = true;
    }
    return true;
  });
  ASSERT_TRUE(sent);
  EXPECT_EQ(odometry.counters().corrections_applied, 1);
  ASSERT_EQ(run.estimates.size(), plain.estimates.size());
  // Sweep to sweep, the corrected output moves like the plain one but for one blending
  // step: within the step limits, never a jump.
  double max_step_m = 0.0, max_step_rad = 0.0;
  for (size_t i = 1; i < run.estimates.size(); ++i) {
    const Eigen::Isometry3d plain_motion =
        plain.estimates[i - 1].T_odom_body.inverse() * plain.estimates[i].T_odom_body;
    const Eigen::Isometry3d motion =
        run.estimates[i - 1].T_odom_body.inverse() * run.estimates[i].T_odom_body;
    const Eigen::Isometry3d step = plain_motion.inverse() * motion;
    max_step_m = std::max(max_step_m, step.translation().norm());
    max_step_rad = std::max(max_step_rad, se3::rotation_angle(step));
  }
  EXPECT_LT(max_step_m, config.correction_max_step_m + 1e-6);
  EXPECT_LT(max_step_rad, config.correction_max_step_rad + 1e-6);
  EXPECT_GT(max_step_m, 0.5 * config.correction_max_step_m) << "the correction was blended in";
  // In the end the correction is all there: the corrected output is the plain one moved
  // by the correction.
  const OdometryEstimate& first_after = plain.estimates[299];
  const Eigen::Isometry3d correction =
      se3::make(so3::exp(Eigen::Vector3d(0, 0, 0.035)), Eigen::Vector3d(1, 0, 0));
  const Eigen::Isometry3d expected = correction * first_after.T_odom_body *
                                     first_after.T_odom_body.inverse() *
                                     plain.estimates.back().T_odom_body;
  EXPECT_LT((run.estimates.back().T_odom_body.translation() - expected.translation()).norm(), 0.01);
  // A correction for a time the odometry never saw is refused.
  OdometryCorrection stale;
  stale.utime_us = 1;
  stale.T_odom_body = Eigen::Isometry3d::Identity();
  odometry.add_correction(stale);
  EXPECT_EQ(odometry.counters().corrections_rejected, 1);
}

// Down a long featureless tunnel: registration is degenerate along it; the filter keeps
// the IMU's motion there instead of diverging.
TEST(Odometry, CorridorIsDegenerateButDoesNotDiverge) {
  sim::WorldConfig world;
  world.kind = "corridor";
  const Recording r = record(
      "corridor",
      {{0, 0}, {world.corridor_length_m, 0}, {world.corridor_length_m, world.corridor_spacing_m}});
  LidarInertialOdometry odometry(config_for(r));
  const eval::TrajectoryMetrics m = replay(r, odometry).metrics(r);
  EXPECT_GT(odometry.counters().degenerate_scans, 50);
  EXPECT_LT(m.ate_position_rmse_m, 0.02 * m.path_length_m);
  EXPECT_LT(m.rpe_translation_percent, 3.0);
}

// The LiDAR's motion as a LiDAR mounted otherwise than configured, or stamped by a clock
// that runs late, would register it: the check names the rotation and the offset.
struct MisconfiguredRig {
  Eigen::Matrix3d R_BF = Eigen::Matrix3d::Identity();  // true mount vs the configured one
  double clock_late_s = 0.0;
  // A lag of the poses that changes with the scene, not the clock: this much more until
  // lag_from_s on.
  double scene_lag_s = 0.0;
  double lag_from_s = 0.0;
  // A LiDAR-only registration that lost the motion: its yaw wanders at random rates of
  // this size (1 sigma) that the IMU never felt.
  double wander_rps = 0.0;
  double drive_s = 30.0;
};

// The check's verdict after the drive: poll() once it is due.
ExtrinsicEstimate check_drive(const MisconfiguredRig& rig) {
  const sim::GeneratedWorld g = sim::generate_world(sim::WorldConfig{});
  sim::SessionPlanConfig lengths;
  lengths.a_length_m = 300.0;
  const sim::SessionPlan plan = sim::plan_session("A", g.world, g.mapped_max_x_m, lengths, 3);
  const sim::VehicleTrajectory trajectory(g.world, plan.waypoints, sim::MotionConfig{}, 3);
  sim::ImuSimulator imu(trajectory, sim::ImuConfig{}, 5, 0);
  ExtrinsicCheck check{ExtrinsicCheckConfig{}};
  sim::Random noise(11);
  double next_pose_s = 0.1;
  double wander_rad = 0.0;
  while (imu.next_time_s() < rig.drive_s) {
    check.add_imu(imu.next());
    const double late_s =
        rig.clock_late_s + (next_pose_s >= rig.lag_from_s ? rig.scene_lag_s : 0.0);
    if (imu.next_time_s() >= next_pose_s + late_s + 0.11) {
      // Registration noise: 1 cm, 0.05 degrees.
      const Eigen::Isometry3d T_local_B = trajectory.pose(next_pose_s);
      const Eigen::Vector3d dp(noise.normal(0.0, 0.01), noise.normal(0.0, 0.01),
                               noise.normal(0.0, 0.01));
      const Eigen::Vector3d dr =
          Eigen::Vector3d(noise.normal(0.0, 1.0), noise.normal(0.0, 1.0), noise.normal(0.0, 1.0)) *
          (0.05 * M_PI / 180.0);
      if (rig.wander_rps > 0.0) {
        wander_rad += noise.normal(0.0, rig.wander_rps) * 0.1;
      }
      check.add_pose(static_cast<int64_t>(std::llround((next_pose_s + late_s) * 1e6)),
                     se3::make(so3::exp(Eigen::Vector3d(0, 0, wander_rad)) * T_local_B.linear() *
                                   rig.R_BF * so3::exp(dr),
                               T_local_B.translation() + dp));
      next_pose_s += 0.1;
    }
  }
  std::optional<ExtrinsicEstimate> verdict = check.poll(Eigen::Matrix3d::Identity(), 0.0);
  EXPECT_TRUE(verdict.has_value());
  return verdict.value_or(ExtrinsicEstimate{});
}

TEST(ExtrinsicCheck, NamesAYawedMountAndALateClock) {
  const ExtrinsicEstimate right = check_drive({});
  EXPECT_LT(right.rotation_error_deg, 1.0);
  EXPECT_LT(std::abs(right.time_offset_error_s), 0.003);
  EXPECT_NEAR(right.gravity_mps2, 9.81, 0.1);

  const Eigen::Matrix3d yawed = so3::from_rpy(Eigen::Vector3d(0, 0, M_PI / 2));
  const ExtrinsicEstimate yaw = check_drive({yawed, 0.0});
  EXPECT_LT(so3::log(yaw.R_BF.transpose() * yawed).norm() * 180.0 / M_PI, 1.5);
  EXPECT_LT(std::abs(yaw.time_offset_error_s), 0.003);

  const Eigen::Matrix3d rolled = so3::from_rpy(Eigen::Vector3d(M_PI / 2, 0, 0.05));
  const ExtrinsicEstimate roll = check_drive({rolled, 0.0});
  EXPECT_LT(so3::log(roll.R_BF.transpose() * rolled).norm() * 180.0 / M_PI, 1.5);

  EXPECT_FALSE(right.warn) << right.message;

  const ExtrinsicEstimate late = check_drive({Eigen::Matrix3d::Identity(), 0.02});
  EXPECT_NEAR(late.time_offset_error_s, 0.02, 0.003);
  EXPECT_LT(late.time_offset_spread_s, 0.005);
  EXPECT_LT(late.rotation_error_deg, 1.0);
  EXPECT_TRUE(late.warn);
  EXPECT_NE(late.message.find("lidar_time_offset_s"), std::string::npos) << late.message;
}

// Poses that lag by 50 ms only from 18 s on (a lag that follows where the sweeps saw
// structure, not the clock) put the whole drive's offset beyond the threshold, but the
// first of its parts says 1 ms: no clock offset is named (a clock 20 ms late throughout
// is, above).
TEST(ExtrinsicCheck, NamesNoOffsetThatThePartsOfTheMotionDisagreeOn) {
  MisconfiguredRig scene;
  scene.scene_lag_s = 0.05;
  scene.lag_from_s = 18.0;
  const ExtrinsicEstimate e = check_drive(scene);
  EXPECT_GT(std::abs(e.time_offset_error_s), ExtrinsicCheckConfig{}.warn_offset_s) << e.message;
  EXPECT_GT(e.time_offset_spread_s, std::abs(e.time_offset_error_s) / 2.0) << e.message;
  EXPECT_FALSE(e.warn) << e.message;
}

// The LiDAR-only twin lost the motion on a correct rig (VLP-16 campus C: its yaw turned at
// 0.2-0.6 rad/s while the gyro felt nothing): the fit is poor, but no mount explains rates of
// another size, so the verdict names the registration and warns of no extrinsic; a yawed
// mount with a healthy registration fits rates of the same size and is named (above).
TEST(ExtrinsicCheck, BlamesALostLidarRegistrationNotTheMount) {
  MisconfiguredRig lost;
  lost.wander_rps = 0.3;
  lost.drive_s = 40.0;  // never certain: the verdict waits for the full window
  const ExtrinsicEstimate e = check_drive(lost);
  EXPECT_GT(e.gyro_rms_rps, 5.0 * ExtrinsicCheckConfig{}.gyro_sigma_rps) << e.message;
  EXPECT_GT(e.rate_magnitude_rms_rps, 5.0 * ExtrinsicCheckConfig{}.gyro_sigma_rps) << e.message;
  EXPECT_FALSE(e.warn) << e.message;
  EXPECT_NE(e.message.find("did not follow the motion"), std::string::npos) << e.message;
  EXPECT_EQ(e.message.find("check the extrinsic"), std::string::npos) << e.message;

  const ExtrinsicEstimate yaw = check_drive({so3::from_rpy(Eigen::Vector3d(0, 0, M_PI / 2))});
  EXPECT_LT(yaw.rate_magnitude_rms_rps, ExtrinsicCheckConfig{}.gyro_sigma_rps) << yaw.message;
  EXPECT_TRUE(yaw.warn) << yaw.message;
}

TEST(ExtrinsicCheck, StandingStillDecidesNothing) {
  ExtrinsicCheckConfig config;
  ExtrinsicCheck check{config};
  // Standing still: nothing to check, whatever the time.
  for (int64_t t = 0; t <= 40000000; t += 100000) {
    check.add_pose(t, Eigen::Isometry3d::Identity());
    EXPECT_FALSE(check.poll(Eigen::Matrix3d::Identity(), 0.0));
  }
  EXPECT_FALSE(check.done());
}

}  // namespace
}  // namespace liloc
