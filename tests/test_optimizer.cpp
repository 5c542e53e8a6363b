#include <gtest/gtest.h>

#include <optional>
#include <random>

#include "map/submap_database.hpp"
#include "math/so3.hpp"
#include "optimizer/egocentric_factor_graph.hpp"
#include "optimizer/localizer.hpp"
#include "optimizer/sliding_target.hpp"
#include "sim_drive.hpp"

namespace liloc {
namespace {

// A simulated drive with its noise-free IMU (plus a constant bias), keyframes every second
// with an odometry that drifts (1 % scale, 0.5 degree of yaw per 10 m), scan matches at the
// truth with a few centimetres of noise, and map keyframes every 2 m along the same road
// as prior nodes.
struct Drive : test::NoiseFreeImuDrive {
  inline static const Eigen::Vector3d kAccelBias{0.04, -0.03, 0.02};
  inline static const Eigen::Vector3d kGyroBias{0.002, -0.001, 0.0015};
  std::vector<std::pair<int64_t, Eigen::Isometry3d>> map_keyframes;
  std::mt19937 rng{3};
  // A fault of the odometry: its pose jumps by this (in the body frame) at jump_at_s.
  double jump_at_s = -1.0;
  Eigen::Isometry3d jump = Eigen::Isometry3d::Identity();
  // The keyframe at this time comes without IMU samples.
  double imu_gap_at_s = -1.0;
  // What the odometry claims of each keyframe's pose (none: the graph's sigmas alone).
  std::optional<Matrix6d> covariance;

  Drive() : NoiseFreeImuDrive(0.2, kAccelBias, kGyroBias) {
    Eigen::Vector3d last(1e9, 0, 0);
    for (double t = 0.0; t < trajectory->duration_s(); t += 0.05) {
      const Eigen::Isometry3d T = trajectory->pose(t);
      if ((T.translation() - last).norm() >= 2.0) {
        map_keyframes.emplace_back(static_cast<int64_t>(map_keyframes.size()), T);
        last = T.translation();
      }
    }
  }
  double duration_s() const { return trajectory->duration_s(); }
  Eigen::Isometry3d truth(double t) const { return trajectory->pose(t); }

  // The drifting odometry: each step's motion scaled and yawed a little.
  Eigen::Isometry3d odometry_step(const Eigen::Isometry3d& T_prev_cur) const {
    Eigen::Isometry3d step = T_prev_cur;
    step.translation() *= 1.01;
    const double yaw = 0.5 * 3.141592653589793 / 180.0 * T_prev_cur.translation().norm() / 10.0;
    step.linear() = so3::exp(Eigen::Vector3d(0, 0, yaw)) * step.linear();
    return step;
  }
  ScanMatch scan_match(const Eigen::Isometry3d& T_truth) {
    std::normal_distribution<double> n(0.0, 1.0);
    Vector6d xi;
    xi << 0.02 * n(rng), 0.02 * n(rng), 0.02 * n(rng), 0.001 * n(rng), 0.001 * n(rng),
        0.001 * n(rng);
    ScanMatch match;
    match.T_map_body = se3::plus(T_truth, xi);
    match.fitness_m = 0.05;
    std::vector<std::pair<double, size_t>> by_distance;
    for (size_t k = 0; k < map_keyframes.size(); ++k) {
      by_distance.emplace_back(
          (map_keyframes[k].second.translation() - T_truth.translation()).norm(), k);
    }
    std::sort(by_distance.begin(), by_distance.end());
    for (size_t k = 0; k < 3; ++k) {
      const auto& [id, T] = map_keyframes[by_distance[k].second];
      match.prior_nodes.push_back({id, T, 0.05 * (1.0 + by_distance[k].first / 5.0)});
    }
    return match;
  }
  std::vector<ImuSample> imu_between(int64_t from_us, int64_t to_us) const {
    std::vector<ImuSample> out;
    for (const ImuSample& s : imu) {
      if (s.utime_us >= from_us - 10000 && s.utime_us <= to_us + 10000) {
        out.push_back(s);
      }
    }
    return out;
  }
};

EgocentricGraphConfig imu_off() {
  EgocentricGraphConfig config;
  config.use_imu = false;
  return config;
}

struct RunResult {
  double max_error_m = 0.0;
  double last_error_m = 0.0;
  double odometry_error_m = 0.0;  // of the odometry alone at the end
  GraphEstimate last;
  int max_window = 0;
  int max_prior_nodes = 0;
  int covariance_failures = 0;
};

// Runs the graph over the drive: scan matches where `rlm(t)` says so (the mode follows).
template <class Rlm>
RunResult run(Drive& drive, EgocentricGraphConfig config, Rlm rlm) {
  EgocentricFactorGraph graph(config);
  RunResult out;
  Eigen::Isometry3d T_odom = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d previous_truth = drive.truth(0.0);
  const double start_s = 4.0;  // after the stationary start
  for (double t = start_s; t < drive.duration_s() - 1.0; t += 1.0) {
    const Eigen::Isometry3d truth = drive.truth(t);
    GraphKeyframe kf;
    kf.id = static_cast<int64_t>(t);
    kf.utime_us = static_cast<int64_t>(t * 1e6);
    if (!graph.started()) {
      T_odom = Eigen::Isometry3d::Identity();
      kf.T_odom_body = T_odom;
      graph.start(kf, truth, Matrix6d::Identity() * 1e-4);
      previous_truth = truth;
      continue;
    }
    T_odom = T_odom * drive.odometry_step(previous_truth.inverse() * truth);
    if (t >= drive.jump_at_s && t - 1.0 < drive.jump_at_s) {
      T_odom = T_odom * drive.jump;
    }
    kf.T_odom_body = T_odom;
    kf.odometry_covariance = drive.covariance;
    if (t != drive.imu_gap_at_s) {
      kf.imu = drive.imu_between(kf.utime_us - 1'000'000, kf.utime_us);
    }
    graph.set_mode(rlm(t) ? LocalizationMode::kRelocalization : LocalizationMode::kIncremental);
    if (rlm(t)) {
      kf.scan_match = drive.scan_match(truth);
    }
    out.last = graph.add(kf);
    const double error = (out.last.T_map_body.translation() - truth.translation()).norm();
    out.max_error_m = std::max(out.max_error_m, error);
    out.last_error_m = error;
    out.max_window = std::max(out.max_window, out.last.window);
    out.max_prior_nodes = std::max(out.max_prior_nodes, out.last.prior_node_count);
    out.covariance_failures += out.last.covariance_ok ? 0 : 1;
    previous_truth = truth;
  }
  const Eigen::Isometry3d T_start = drive.truth(start_s);
  out.odometry_error_m = ((T_start * T_odom).translation() - previous_truth.translation()).norm();
  return out;
}

TEST(EgocentricFactorGraph, ScanMatchesHoldTheDriftingOdometryToTheMap) {
  Drive drive;
  ASSERT_GT(drive.duration_s(), 60.0);
  const RunResult r = run(drive, EgocentricGraphConfig{}, [](double) { return true; });
  EXPECT_GT(r.odometry_error_m, 1.0);  // the odometry alone drifts
  EXPECT_LT(r.max_error_m, 0.08);
  EXPECT_LT(r.last_error_m, 0.05);
  // Bounded: N_m^r keyframes, N_d prior nodes for each of them at most.
  EXPECT_EQ(r.max_window, 5);
  EXPECT_LE(r.max_prior_nodes, 5 * 3);
  EXPECT_TRUE(r.last.imu_factor);
  EXPECT_EQ(r.last.scan_match_factors, 3);
  // The IMU biases are estimated jointly.
  EXPECT_LT((r.last.bias.gyro_rps - Drive::kGyroBias).norm(), 1e-3);
  EXPECT_LT((r.last.bias.accel_mps2 - Drive::kAccelBias).norm(), 0.03);
}

// The second keyframe comes without IMU samples (as after a slow start): the IMU factors
// begin a new chain at it, whose biases get their prior again; every covariance is
// computed (without that prior the bias and the velocity traded off, rank deficient).
TEST(EgocentricFactorGraph, AnImuGapStartsANewChain) {
  Drive drive;
  drive.imu_gap_at_s = 5.0;
  const RunResult r = run(drive, EgocentricGraphConfig{}, [](double) { return true; });
  EXPECT_EQ(r.covariance_failures, 0);
  EXPECT_TRUE(r.last.imu_factor);
  EXPECT_LT(r.max_error_m, 0.08);
  EXPECT_LT((r.last.bias.gyro_rps - Drive::kGyroBias).norm(), 1e-3);
}

// Out of the map (ILM) the window grows to N_m^l and the estimate follows the odometry; back
// in (RLM) it shrinks to N_m^r, the marginal prior carried across both switches.
TEST(EgocentricFactorGraph, ModesChangeTheWindowAndCarryTheMarginalPrior) {
  Drive drive;
  const auto inside = [](double t) { return t < 30.0 || t > 45.0; };
  const RunResult r = run(drive, EgocentricGraphConfig{}, inside);
  EXPECT_EQ(r.max_window, 10);
  EXPECT_EQ(r.last.window, 5);
  EXPECT_LT(r.last_error_m, 0.05);  // relocalized after the ILM stretch
  // 15 s of ILM with an odometry that drifts 1 % and 0.5 degree per 10 m: the IMU factors
  // hold the estimate better than the odometry factors alone (seen: 1.9 m against 2.8 m;
  // the odometry alone drifts 26 m over the drive).
  const RunResult without_imu = run(drive, imu_off(), inside);
  EXPECT_LT(r.max_error_m, 0.8 * without_imu.max_error_m);
  EXPECT_LT(r.max_error_m, 0.1 * r.odometry_error_m);
  EgocentricGraphConfig growing;
  growing.no_marginalization = true;
  EXPECT_GT(run(drive, growing, inside).max_window, 30);
}

// The odometry's pose jumps by 1.2 m and 4.6 degrees at 30 s.
Drive jumping_drive() {
  Drive drive;
  drive.jump_at_s = 30.0;
  drive.jump = se3::make(so3::exp(Eigen::Vector3d(0.0, 0.0, 0.08)), Eigen::Vector3d(0.8, 0.9, 0.0));
  return drive;
}

// The odometry jumps (a restart, a bad registration) by 1.2 m and 4.6 degrees between two
// keyframes inside the map, under the correction gate (1.5 m): the scan matches outvote it
// at once. (With the odometry trusted to 1 mm the estimate follows it: 49 m.)
TEST(EgocentricFactorGraph, AnOdometryJumpIsOutvotedByTheMap) {
  Drive drive = jumping_drive();
  const RunResult r = run(drive, EgocentricGraphConfig{}, [](double) { return true; });
  EXPECT_LT(r.max_error_m, 0.08);
  EXPECT_LT(r.last_error_m, 0.05);
}

// The same jump from an odometry that claims millimetres (its covariance), with the IMU
// factors: the odometry factor's floor is small there, and only its robust loss lets the
// map and the IMU outvote it (seen: 0.072 m; without the loss 1.26 m at the jump).
TEST(EgocentricFactorGraph, AnOdometryThatClaimsMillimetresAndJumpsIsOutvoted) {
  Drive drive = jumping_drive();
  drive.covariance = Matrix6d::Identity() * 1e-6;
  const RunResult r = run(drive, EgocentricGraphConfig{}, [](double) { return true; });
  EXPECT_TRUE(r.last.imu_factor);
  EXPECT_LT(r.max_error_m, 0.1);
  EXPECT_LT(r.last_error_m, 0.05);
}

TEST(EgocentricFactorGraph, RefusesKeyframesOutOfOrder) {
  EgocentricFactorGraph graph(EgocentricGraphConfig{});
  GraphKeyframe kf;
  kf.utime_us = 1'000'000;
  EXPECT_THROW(graph.add(kf), std::logic_error);
  graph.start(kf, Eigen::Isometry3d::Identity(), Matrix6d::Identity());
  EXPECT_THROW(graph.add(kf), std::invalid_argument);
  EgocentricGraphConfig bad;
  bad.window_rlm = 1;
  EXPECT_THROW(EgocentricFactorGraph{bad}, std::invalid_argument);
}

// A scan match in a tunnel along x at `position`, propagated to the map keyframes at
// x = k - 1, k and k + 1.
ScanMatch tunnel_match(int k, const Eigen::Vector3d& position) {
  ScanMatch match;
  match.T_map_body.translation() = position;
  for (int i = 0; i < 3; ++i) {
    Eigen::Isometry3d T_map_keyframe = Eigen::Isometry3d::Identity();
    T_map_keyframe.translation() = Eigen::Vector3d(k + i - 1.0, 0.0, 0.0);
    match.prior_nodes.push_back({100 + k + i, T_map_keyframe, 0.05});
  }
  return match;
}

// A corridor along x: every registration slid 1 m along the tunnel (where nothing fixes it)
// but holds y, z and the rotation. With the registration's information, weak along x, the
// scan-match factors hold the estimate to the map across the tunnel and leave the axis to
// the odometry (exact here); with the base noise alone they would pull it 1 m along.
TEST(EgocentricFactorGraph, DegenerateScanMatchDoesNotPullAlongItsWeakAxis) {
  const auto run_corridor = [](const std::optional<Matrix6d>& information) {
    EgocentricGraphConfig config;
    EgocentricFactorGraph graph(config);
    GraphKeyframe kf;
    kf.utime_us = 1'000'000;
    // Started 0.3 m off across the tunnel, known loosely across (1 m) and well along it
    // (1 cm, where the tunnel started): the scan matches must bring it back across.
    Vector6d variance;
    variance << 1e-4, 1.0, 1e-4, 1e-6, 1e-6, 1e-6;
    graph.start(kf, se3::make(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.0, 0.3, 0.0)),
                variance.asDiagonal());
    GraphEstimate last;
    for (int k = 1; k <= 30; ++k) {
      kf.id = k;
      kf.utime_us += 1'000'000;
      const Eigen::Vector3d truth(k, 0.0, 0.0);
      kf.T_odom_body.translation() = truth;
      ScanMatch match = tunnel_match(k, truth + Eigen::Vector3d(1.0, 0.0, 0.0));
      match.information = information;
      kf.scan_match = match;
      last = graph.add(kf);
      EXPECT_EQ(last.scan_match_factors, 3);
    }
    return Eigen::Vector3d(last.T_map_body.translation() - Eigen::Vector3d(30.0, 0.0, 0.0));
  };
  Matrix6d weak_along_x = Matrix6d::Identity() * 1e8;
  weak_along_x(0, 0) = 1e-4;  // 100 m sigma along the tunnel, 0.1 mm across
  const Eigen::Vector3d degenerate = run_corridor(weak_along_x);
  EXPECT_LT(std::abs(degenerate.x()), 0.05);  // the odometry's, not the slid registration's
  EXPECT_LT(std::abs(degenerate.y()), 0.01);  // held across the tunnel
  const Eigen::Vector3d base_only = run_corridor(std::nullopt);
  EXPECT_GT(base_only.x(), 0.8);
  EXPECT_LT(std::abs(base_only.y()), 0.01);
}

// The converse: the odometry slides along a tunnel (1.5 m for every metre driven) and says
// so in its covariance (1 m along x, millimetres across). Eq. 7 with that covariance gives
// way along x to the scan matches (exact here): within 1 mm of them. With the fixed sigmas
// alone (3.5 cm for a step) the odometry pulls against them, and their robust kernel lets
// it: 1.5 cm off.
TEST(EgocentricFactorGraph, SlidingOdometryGivesWayAlongItsWeakAxis) {
  const auto run_corridor = [](bool odometry_covariance) {
    EgocentricGraphConfig config;
    config.odometry_covariance = odometry_covariance;
    config.odometry_loss_scale = 0.0;  // the covariance's effect alone
    EgocentricFactorGraph graph(config);
    Vector6d variance;
    variance << 1.0, 1e-6, 1e-6, 1e-8, 1e-8, 1e-8;
    GraphKeyframe kf;
    kf.utime_us = 1'000'000;
    kf.odometry_covariance = Matrix6d(variance.asDiagonal());
    graph.start(kf, Eigen::Isometry3d::Identity(), Matrix6d::Identity() * 1e-4);
    double max_error_m = 0.0;
    for (int k = 1; k <= 30; ++k) {
      kf.id = k;
      kf.utime_us += 1'000'000;
      const Eigen::Vector3d truth(k, 0.0, 0.0);
      kf.T_odom_body.translation() = 1.5 * truth;
      ScanMatch match = tunnel_match(k, truth);
      kf.scan_match = match;
      const GraphEstimate estimate = graph.add(kf);
      max_error_m = std::max(max_error_m, (estimate.T_map_body.translation() - truth).norm());
    }
    return max_error_m;
  };
  EXPECT_LT(run_corridor(true), 0.001);
  EXPECT_GT(run_corridor(false), 0.01);
}

// The overlap of Eq. 11 on a hand-made map: one submap whose bounds are x in [0, 100], y in [-20,
// 20]. The square [x +- 10, y +- 10] around the predicted position: fully inside at x = 50 (RLM),
// 75 % inside at x = 95 (RLM), 25 % at x = 105 (ILM). The map has no clouds, so the scan
// match waits for its submaps and says so.
TEST(Localizer, ModeFollowsTheOverlapOfEq11) {
  MapData map;
  for (int k = 0; k < 11; ++k) {
    MapKeyframe kf;
    kf.id = k;
    kf.T_map_body.translation() = Eigen::Vector3d(15.0 + 7.0 * k, 0.0, 0.0);
    map.keyframes.push_back(kf);
  }
  Submap submap;
  submap.id = 0;
  for (MapKeyframe& kf : map.keyframes) {
    kf.submap_id = 0;
    submap.keyframe_ids.push_back(kf.id);
  }
  submap.centroid = Eigen::Vector3d(50.0, 0.0, 0.0);
  submap.bounds = {0.0, 100.0, -20.0, 20.0};
  map.submaps.push_back(submap);
  const MapIndex index(map, {}, PolarDescriptorConfig{});
  const SubmapTargets targets([](int64_t) { return nullptr; });
  LocalizerConfig config;
  Localizer localizer(config, index, targets);
  LocalizerKeyframe kf;
  kf.utime_us = 1'000'000;
  localizer.start(kf, Eigen::Isometry3d::Identity(), Matrix6d::Identity() * 1e-4);
  const auto at = [&](double x) {
    kf.id += 1;
    kf.utime_us += 1'000'000;
    kf.T_odom_body.translation() = Eigen::Vector3d(x, 0.0, 0.0);
    return localizer.add(kf);
  };
  const LocalizerOutput inside = at(50.0);
  EXPECT_DOUBLE_EQ(inside.overlap, 1.0);
  EXPECT_EQ(inside.mode, LocalizationMode::kRelocalization);
  EXPECT_FALSE(inside.scan_matched);
  EXPECT_EQ(inside.gate, "waiting for 1 submap(s)");
  EXPECT_EQ(inside.missing_submaps, std::vector<int64_t>{0});
  const LocalizerOutput edge = at(95.0);
  EXPECT_NEAR(edge.overlap, 0.75, 1e-9);
  EXPECT_EQ(edge.mode, LocalizationMode::kRelocalization);
  const LocalizerOutput outside = at(105.0);
  EXPECT_NEAR(outside.overlap, 0.25, 1e-9);
  EXPECT_EQ(outside.mode, LocalizationMode::kIncremental);
  EXPECT_TRUE(outside.gate.empty());                               // ILM: no scan match tried
  EXPECT_NEAR(outside.T_map_body.translation().x(), 105.0, 1e-6);  // the odometry carries it
}

// Submaps within reach are inserted when the registration needs them; the nearest one just
// beyond goes in after the pose is out (prefetch), so that no keyframe pays for it; what
// falls far behind leaves. Submap 0 at the robot, 1 at 50 m (ahead), 2 at 55 m (ahead,
// not fetched yet).
TEST(SlidingTarget, InsertsWhatIsInReachPrefetchesTheNextAndForgetsTheFar) {
  MapData map;
  for (int k = 0; k < 3; ++k) {
    MapKeyframe kf;
    kf.id = k;
    kf.submap_id = k;
    kf.T_map_body.translation() = Eigen::Vector3d(k == 0 ? 0.0 : 45.0 + 5.0 * k, 0.0, 0.0);
    map.keyframes.push_back(kf);
    Submap submap;
    submap.id = k;
    submap.keyframe_ids = {k};
    submap.centroid = kf.T_map_body.translation();
    submap.bounds = {submap.centroid.x() - 10, submap.centroid.x() + 10, -10.0, 10.0};
    map.submaps.push_back(submap);
  }
  const MapIndex index(map, {}, PolarDescriptorConfig{});
  // 40 000 points a submap, 0.2 m apart on a 200 x 200 grid around its centroid.
  const auto cloud = [&](int64_t id) {
    auto points = std::make_shared<std::vector<Eigen::Vector3f>>();
    const Eigen::Vector3f c = map.submaps[static_cast<size_t>(id)].centroid.cast<float>();
    for (int i = 0; i < 200; ++i) {
      for (int j = 0; j < 200; ++j) {
        points->push_back(c + Eigen::Vector3f(0.2f * i - 20.0f, 0.2f * j - 20.0f, 0.0f));
      }
    }
    return std::shared_ptr<const std::vector<Eigen::Vector3f>>(points);
  };
  const SubmapTargets targets([&](int64_t id) { return id == 2 ? nullptr : cloud(id); });
  SlidingTarget target({0.5}, 35.0, 30.0, 200.0);
  const Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  const SlidingTarget::Update first = target.update(index, targets, origin);
  EXPECT_TRUE(first.missing.empty());
  EXPECT_EQ(first.upcoming, std::vector<int64_t>{2});
  EXPECT_EQ(target.submaps(), 1u);  // submap 0 only: 1 is beyond reach
  EXPECT_EQ(target.stage(0).num_points(), 40000u);
  target.prefetch(index, targets, origin);
  EXPECT_EQ(target.submaps(), 2u);  // submap 1 whole
  EXPECT_EQ(target.stage(0).num_points(), 80000u);
  target.prefetch(index, targets, origin);  // submap 2 is not there to insert
  EXPECT_EQ(target.submaps(), 2u);
  // At 50 m submap 2 is within reach and still not there: the scan match must wait.
  EXPECT_EQ(target.update(index, targets, Eigen::Vector3d(50.0, 0.0, 0.0)).missing,
            std::vector<int64_t>{2});
  // 300 m on, both submaps are forgotten and their voxels gone (beyond keep_m, 200 m).
  target.prefetch(index, targets, Eigen::Vector3d(300.0, 0.0, 0.0));
  EXPECT_EQ(target.submaps(), 0u);
  EXPECT_EQ(target.stage(0).num_points(), 0u);
  // At a start, the prefetch puts in everything within reach and the next one beyond, so
  // that the first keyframe's registration inserts nothing.
  SlidingTarget started({0.5}, 35.0, 30.0, 200.0);
  started.prefetch(index, targets, origin);
  EXPECT_EQ(started.submaps(), 2u);
  EXPECT_EQ(started.stage(0).num_points(), 80000u);
}

}  // namespace
}  // namespace liloc
