#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numeric>
#include <random>
#include <sstream>

#include "eval/eval_report.hpp"
#include "eval/json_writer.hpp"
#include "eval/latency_stats.hpp"
#include "eval/mode_timeline.hpp"
#include "eval/trajectory_metrics.hpp"
#include "eval/trajectory_plot.hpp"
#include "math/se3.hpp"
#include "math/so3.hpp"

namespace liloc::eval {
namespace {

constexpr double kPi = M_PI;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

Eigen::Isometry3d rot_z(double angle_rad) {
  return se3::make(so3::exp(Eigen::Vector3d(0, 0, angle_rad)), Eigen::Vector3d::Zero());
}

Eigen::Isometry3d translation(const Eigen::Vector3d& t) {
  return se3::make(Eigen::Matrix3d::Identity(), t);
}

// n poses at times 0, dt, 2 dt ..., pose k = f(k).
Trajectory make_trajectory(int n, double dt, const std::function<Eigen::Isometry3d(int)>& f) {
  std::vector<StampedPose> poses;
  for (int k = 0; k < n; ++k) {
    poses.push_back({k * dt, f(k)});
  }
  return Trajectory(poses);
}

// About 500 m of a wavy 3D path with heading along the motion plus roll and pitch,
// so that no alignment is degenerate.
Trajectory wavy_ground_truth() {
  return make_trajectory(500, 0.1, [](int k) {
    const double s = k;
    const Eigen::Vector3d p(s, 20.0 * std::sin(s / 40.0), 2.0 * std::sin(s / 25.0));
    const Eigen::Vector3d rpy(0.05 * std::sin(s / 30.0), 0.03 * std::cos(s / 20.0),
                              std::atan(0.5 * std::cos(s / 40.0)));
    return se3::make(so3::exp(Eigen::Vector3d(0, 0, rpy.z())) *
                         so3::exp(Eigen::Vector3d(0, rpy.y(), 0)) *
                         so3::exp(Eigen::Vector3d(rpy.x(), 0, 0)),
                     p);
  });
}

// Applies T_left * T * T_right to every pose.
Trajectory transformed(const Trajectory& trajectory, const Eigen::Isometry3d& T_left,
                       const Eigen::Isometry3d& T_right = Eigen::Isometry3d::Identity()) {
  std::vector<StampedPose> poses;
  for (const StampedPose& p : trajectory.poses()) {
    poses.push_back({p.time_s, T_left * p.T * T_right});
  }
  return Trajectory(poses);
}

EvalConfig with_alignment(AlignmentMode mode) {
  EvalConfig config;
  config.alignment = mode;
  return config;
}

TEST(EvalMetrics, IdenticalTrajectoriesHaveZeroError) {
  const Trajectory gt = wavy_ground_truth();
  for (const AlignmentMode mode :
       {AlignmentMode::kSe3, AlignmentMode::kFirst, AlignmentMode::kNone}) {
    const TrajectoryMetrics m = evaluate_trajectory(gt, gt, with_alignment(mode));
    EXPECT_EQ(m.matched_poses, 500u);
    EXPECT_EQ(m.skipped_poses, 0u);
    EXPECT_NEAR(m.ate_position_rmse_m, 0.0, 1e-9) << to_string(mode);
    EXPECT_NEAR(m.ate_position_max_m, 0.0, 1e-9);
    EXPECT_NEAR(m.ate_full_rmse, 0.0, 1e-9);
    EXPECT_NEAR(m.rotation_rmse_deg, 0.0, 1e-6);
    EXPECT_GT(m.rpe_segments, 0u);
    EXPECT_NEAR(m.rpe_translation_percent, 0.0, 1e-9);
    EXPECT_NEAR(m.rpe_rotation_deg_per_100m, 0.0, 1e-6);
    EXPECT_TRUE(m.T_gt_est.isApprox(Eigen::Isometry3d::Identity(), 1e-9));
    EXPECT_NEAR(m.duration_s, 49.9, 1e-9);
    EXPECT_NEAR(m.path_length_m, gt.path_length_m(), 1e-9);
    EXPECT_TRUE(m.warnings.empty());
  }
}

TEST(EvalMetrics, PositionOffsetGivesAteFiveUnalignedAndZeroAfterSe3) {
  const Trajectory gt = wavy_ground_truth();
  const Trajectory est = transformed(gt, translation({3, 4, 0}));

  const TrajectoryMetrics none = evaluate_trajectory(gt, est, with_alignment(AlignmentMode::kNone));
  EXPECT_NEAR(none.ate_position_rmse_m, 5.0, 1e-9);
  EXPECT_NEAR(none.ate_position_max_m, 5.0, 1e-9);
  // T_gt^-1 T_est is a pure translation of norm 5: ||E - I||_F = 5.
  EXPECT_NEAR(none.ate_full_rmse, 5.0, 1e-9);
  EXPECT_NEAR(none.rotation_rmse_deg, 0.0, 1e-6);
  // RPE does not depend on a constant frame offset.
  EXPECT_NEAR(none.rpe_translation_percent, 0.0, 1e-9);

  const TrajectoryMetrics se3 = evaluate_trajectory(gt, est, with_alignment(AlignmentMode::kSe3));
  EXPECT_NEAR(se3.ate_position_rmse_m, 0.0, 1e-6);
  EXPECT_TRUE(se3.T_gt_est.translation().isApprox(Eigen::Vector3d(-3, -4, 0), 1e-6))
      << se3.T_gt_est.translation().transpose();
}

TEST(EvalMetrics, BodyRotationOffsetGivesRotationRmse) {
  const Trajectory gt = wavy_ground_truth();
  const double ten_deg = 10.0 * kPi / 180.0;
  // Rotated in the body frame: same positions, every orientation off by 10 deg.
  const Trajectory est = transformed(gt, Eigen::Isometry3d::Identity(), rot_z(ten_deg));
  const TrajectoryMetrics m = evaluate_trajectory(gt, est, with_alignment(AlignmentMode::kNone));
  EXPECT_NEAR(m.rotation_rmse_deg, 10.0, 1e-9);
  EXPECT_NEAR(m.ate_position_rmse_m, 0.0, 1e-9);
  // ||Rz(a) - I||_F = sqrt(4 (1 - cos a)).
  EXPECT_NEAR(m.ate_full_rmse, std::sqrt(4.0 * (1.0 - std::cos(ten_deg))), 1e-12);
}

TEST(EvalMetrics, FrameRotationIsRemovedBySe3Alignment) {
  const Trajectory gt = wavy_ground_truth();
  const double ten_deg = 10.0 * kPi / 180.0;
  // The estimate's frame is rotated: positions and orientations change together.
  const Trajectory est = transformed(gt, rot_z(ten_deg));
  const TrajectoryMetrics none = evaluate_trajectory(gt, est, with_alignment(AlignmentMode::kNone));
  EXPECT_NEAR(none.rotation_rmse_deg, 10.0, 1e-9);
  EXPECT_GT(none.ate_position_rmse_m, 10.0);

  const TrajectoryMetrics se3 = evaluate_trajectory(gt, est, with_alignment(AlignmentMode::kSe3));
  EXPECT_NEAR(se3.ate_position_rmse_m, 0.0, 1e-6);
  EXPECT_NEAR(se3.rotation_rmse_deg, 0.0, 1e-5);
  EXPECT_TRUE(se3.T_gt_est.isApprox(rot_z(-ten_deg), 1e-9));
}

TEST(EvalMetrics, FirstAlignmentTiesTheFirstPoses) {
  const Trajectory gt = wavy_ground_truth();
  const Eigen::Isometry3d T_est_gt = translation({10, -5, 1}) * rot_z(0.7);
  const Trajectory est = transformed(gt, T_est_gt);
  const TrajectoryMetrics m = evaluate_trajectory(gt, est, with_alignment(AlignmentMode::kFirst));
  EXPECT_NEAR(m.ate_position_rmse_m, 0.0, 1e-9);
  EXPECT_TRUE(m.T_gt_est.isApprox(T_est_gt.inverse(), 1e-12));
}

// Subsidiary sessions are scored in session A's frame: the given transform is applied
// as is, and an error that a refit would hide stays visible.
TEST(EvalMetrics, FixedAlignmentIsNeverRefitted) {
  const Trajectory gt = wavy_ground_truth();
  const Eigen::Isometry3d T_gt_map = translation({100, 50, -2}) * rot_z(1.2);
  const Eigen::Isometry3d T_map_gt = T_gt_map.inverse();
  EvalConfig config = with_alignment(AlignmentMode::kFixed);
  config.T_gt_est_fixed = T_gt_map;

  const TrajectoryMetrics exact = evaluate_trajectory(gt, transformed(gt, T_map_gt), config);
  EXPECT_NEAR(exact.ate_position_rmse_m, 0.0, 1e-9);
  EXPECT_TRUE(exact.T_gt_est.isApprox(T_gt_map, 1e-15));

  // The session sits 5 m off in the map frame (in a direction that is (3, 4, 0) in GT).
  const Eigen::Vector3d offset_map = T_map_gt.linear() * Eigen::Vector3d(3, 4, 0);
  const Trajectory shifted = transformed(gt, translation(offset_map) * T_map_gt);
  EXPECT_NEAR(evaluate_trajectory(gt, shifted, config).ate_position_rmse_m, 5.0, 1e-9);
  EXPECT_NEAR(
      evaluate_trajectory(gt, shifted, with_alignment(AlignmentMode::kSe3)).ate_position_rmse_m,
      0.0, 1e-6);
}

TEST(EvalMetrics, FullPoseErrorOfAKnownOffset) {
  const Trajectory gt = wavy_ground_truth();
  const Eigen::Vector3d t(0.3, -0.2, 0.1);
  const double angle = 0.1;
  const Trajectory est =
      transformed(gt, Eigen::Isometry3d::Identity(), translation(t) * rot_z(angle));
  const TrajectoryMetrics m = evaluate_trajectory(gt, est, with_alignment(AlignmentMode::kNone));
  // E = [Rz(0.1), t; 0, 1] at every pose. ||E - I||_F^2 = ||Rz - I||_F^2 + |t|^2, with
  // ||Rz - I||_F^2 = 2 (cos a - 1)^2 + 2 sin^2 a = 4 (1 - cos a) = 0.0199833389;
  // |t|^2 = 0.09 + 0.04 + 0.01 = 0.14; sqrt(0.1599833389) = 0.3999791731.
  EXPECT_NEAR(m.ate_full_rmse, 0.3999791731, 1e-9);
  EXPECT_NEAR(m.ate_position_rmse_m, std::sqrt(0.14), 1e-12);
  EXPECT_NEAR(m.rotation_rmse_deg, 0.1 * 180.0 / kPi, 1e-9);
}

// 300 m straight along x, one pose every 1.5 m, the body yawed by 30 deg; the estimate
// drifts sideways (world y) by 1 % of the distance travelled, orientations exact.
// Segment i -> j: the first pose at least 100 m on, so L = 67 * 1.5 = 100.5 m.
// T_gt_ij = [I, R^T (L, 0, 0)], T_est_ij = [I, R^T (L, 0.01 L, 0)], so
// E = [I, R^T (0, 0.01 L, 0)] and |t(E)| / L = 1 % exactly (dividing by the nominal
// 100 m instead would give 1.005 %). Starts 0 ... 133 (pose 200 is the last end): 134.
TEST(EvalMetrics, LinearLateralDriftGivesOnePercentRpe) {
  const Eigen::Isometry3d yaw = rot_z(30.0 * kPi / 180.0);
  const Trajectory gt = make_trajectory(201, 0.1, [&](int k) {
    return translation({1.5 * k, 0, 0}) * yaw;
  });
  const Trajectory est = make_trajectory(201, 0.1, [&](int k) {
    return translation({1.5 * k, 0.015 * k, 0}) * yaw;
  });
  const TrajectoryMetrics m = evaluate_trajectory(gt, est, with_alignment(AlignmentMode::kNone));
  EXPECT_EQ(m.rpe_segments, 134u);
  EXPECT_NEAR(m.rpe_translation_percent, 1.0, 1e-9);
  EXPECT_NEAR(m.rpe_rotation_deg_per_100m, 0.0, 1e-9);
  EXPECT_NEAR(m.path_length_m, 300.0, 1e-12);
  // Unaligned ATE: errors 0.015 k for k = 0 ... 200: RMSE = 0.015 sqrt(sum k^2 / 201)
  // = 0.015 sqrt(200 * 401 / 6).
  EXPECT_NEAR(m.ate_position_rmse_m, 0.015 * std::sqrt(200.0 * 401.0 / 6.0), 1e-9);
}

// The same drift with the estimated heading along its own (drifted) direction: in the
// body frame it moves (L sqrt(1 + k^2), 0, 0), so RPE only sees the longer path,
// (sqrt(1.0001) - 1) * 100 % = 0.0049999 %, and the heading offset (no relative rotation).
TEST(EvalMetrics, DriftAlongTheEstimatedHeadingIsOnlyAScaleError) {
  const double k_drift = 0.01;
  const Trajectory gt = make_trajectory(301, 0.1, [](int k) {
    return translation({double(k), 0, 0});
  });
  const Trajectory est = make_trajectory(301, 0.1, [&](int k) {
    return translation({double(k), k_drift * k, 0}) * rot_z(std::atan(k_drift));
  });
  const TrajectoryMetrics m = evaluate_trajectory(gt, est, with_alignment(AlignmentMode::kNone));
  EXPECT_NEAR(m.rpe_translation_percent, (std::sqrt(1.0 + k_drift * k_drift) - 1.0) * 100.0, 1e-9);
  EXPECT_NEAR(m.rpe_rotation_deg_per_100m, 0.0, 1e-9);
}

TEST(EvalMetrics, RpeIsNanWhenShorterThanOneSegment) {
  const Trajectory gt = make_trajectory(51, 0.1, [](int k) {
    return translation({double(k), 0, 0});
  });
  const TrajectoryMetrics m = evaluate_trajectory(gt, gt, EvalConfig{});
  EXPECT_EQ(m.rpe_segments, 0u);
  EXPECT_TRUE(std::isnan(m.rpe_translation_percent));
  EXPECT_TRUE(std::isnan(m.rpe_rotation_deg_per_100m));
  ASSERT_EQ(m.warnings.size(), 1u);
  EXPECT_NE(m.warnings[0].find("RPE not computed"), std::string::npos) << m.warnings[0];
  EXPECT_NEAR(m.ate_position_rmse_m, 0.0, 1e-12);  // the rest is still scored
}

// Times are multiples of 1/8 s, exact in binary. Ground truth 0 ... 10 s with a gap
// (4, 5) s; the estimate runs -1 ... 11 s.
TEST(EvalAssociation, SkipsEstimatesWithoutGroundTruth) {
  std::vector<StampedPose> gt_poses;
  for (int k = 0; k <= 80; ++k) {
    if (k < 33 || k > 39) {
      gt_poses.push_back({0.125 * k, translation({0.125 * k, 0, 0})});
    }
  }
  const Trajectory gt(gt_poses);
  std::vector<StampedPose> est_poses;
  for (int k = 0; k <= 96; ++k) {
    const double t = -1.0 + 0.125 * k;
    est_poses.push_back({t, translation({t, 0, 0})});
  }
  const Trajectory est(est_poses);
  const Association a = associate(gt, est, 0.2);
  // Outside [0, 10] s: 8 before, 8 after; inside the gap 4.125 ... 4.875 s: 7.
  EXPECT_EQ(a.skipped, 23u);
  EXPECT_EQ(a.pairs.size(), 97u - 23u);
  EXPECT_EQ(a.pairs.front().time_s, 0.0);
  EXPECT_EQ(a.pairs.back().time_s, 10.0);
  for (const PosePair& pair : a.pairs) {
    EXPECT_TRUE(pair.time_s <= 4.0 || pair.time_s >= 5.0) << pair.time_s;
  }
  const TrajectoryMetrics m = evaluate_trajectory(gt, est, [] {
    EvalConfig c;
    c.max_time_gap_s = 0.2;
    return c;
  }());
  EXPECT_EQ(m.matched_poses, 74u);
  EXPECT_EQ(m.skipped_poses, 23u);
  EXPECT_EQ(m.warnings.size(), 2u);  // the skipped poses and the short path for RPE
}

TEST(EvalAssociation, InterpolatesGroundTruthBetweenPoses) {
  const Trajectory gt = make_trajectory(11, 1.0, [](int k) {
    return translation({2.0 * k, 0, 0});
  });
  const Trajectory est({{2.5, translation({5.0, 0, 0})}});
  const Association a = associate(gt, est, 1.5);
  ASSERT_EQ(a.pairs.size(), 1u);
  EXPECT_TRUE(a.pairs[0].T_gt_body.translation().isApprox(Eigen::Vector3d(5, 0, 0)));
  EXPECT_EQ(associate(gt, est, 0.5).skipped, 1u);  // ground-truth poses 1 s apart
}

// 10 Hz ground truth at Unix-epoch times: its gaps read 0.1 s +- 2e-7 after round-off and
// must still count as within the default 0.1 s.
TEST(EvalAssociation, TenHertzGroundTruthAtEpochTimesMatchesTheDefaultGap) {
  const double t0 = 1700000000.0;
  std::vector<StampedPose> gt_poses, est_poses;
  for (int k = 0; k <= 600; ++k) {
    gt_poses.push_back({t0 + 0.1 * k, translation({double(k), 0, 0})});
    if (k < 600) {
      est_poses.push_back({t0 + 0.1 * k + 0.05, translation({k + 0.5, 0, 0})});
    }
  }
  const Association a =
      associate(Trajectory(gt_poses), Trajectory(est_poses), EvalConfig{}.max_time_gap_s);
  EXPECT_EQ(a.skipped, 0u);
  EXPECT_EQ(a.pairs.size(), 600u);
}

TEST(EvalMetrics, NoMatchedPoseIsAnError) {
  const Trajectory gt = make_trajectory(10, 1.0, [](int k) {
    return translation({double(k), 0, 0});
  });
  const Trajectory est({{100.0, Eigen::Isometry3d::Identity()}});
  EXPECT_THROW(evaluate_trajectory(gt, est, EvalConfig{}), std::invalid_argument);
  EvalConfig bad;
  bad.rpe_segment_m = 0.0;
  EXPECT_THROW(evaluate_trajectory(gt, gt, bad), std::invalid_argument);
}

TEST(EvalAlignment, ParsesModeNames) {
  EXPECT_EQ(parse_alignment_mode("se3"), AlignmentMode::kSe3);
  EXPECT_EQ(parse_alignment_mode("first"), AlignmentMode::kFirst);
  EXPECT_EQ(parse_alignment_mode("none"), AlignmentMode::kNone);
  EXPECT_THROW(parse_alignment_mode("fixed"), std::invalid_argument);
  EXPECT_THROW(parse_alignment_mode("sim3"), std::invalid_argument);
}

TEST(EvalAlignment, RigidFitRecoversAKnownTransformFromNoisyPoints) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.01);
  const Eigen::Isometry3d T_gt_est =
      translation({1, 2, 3}) *
      se3::make(so3::exp(Eigen::Vector3d(0.2, -0.1, 0.9)), Eigen::Vector3d::Zero());
  std::vector<Eigen::Vector3d> est, gt;
  for (int k = 0; k < 200; ++k) {
    const Eigen::Vector3d p(std::cos(0.1 * k) * 30, std::sin(0.07 * k) * 20, 0.05 * k);
    est.push_back(p);
    gt.push_back(T_gt_est * p + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
  }
  const Eigen::Isometry3d fitted = fit_rigid_alignment(est, gt);
  EXPECT_TRUE(fitted.linear().isApprox(T_gt_est.linear(), 1e-3));
  EXPECT_TRUE(fitted.translation().isApprox(T_gt_est.translation(), 1e-2));
  EXPECT_NEAR(fitted.linear().determinant(), 1.0, 1e-12);  // a rotation, not a reflection
}

TEST(LatencyStats, PercentilesOfOneToHundred) {
  std::vector<double> ms(100);
  std::iota(ms.begin(), ms.end(), 1.0);
  std::shuffle(ms.begin(), ms.end(), std::mt19937(3));
  const LatencyStats s = compute_latency_stats(ms);
  EXPECT_EQ(s.count, 100u);
  EXPECT_DOUBLE_EQ(s.median_ms, 50.5);
  EXPECT_DOUBLE_EQ(s.p95_ms, 95.05);  // index 0.95 * 99 = 94.05 -> 95 + 0.05
  EXPECT_DOUBLE_EQ(s.p99_ms, 99.01);  // index 98.01 -> 99 + 0.01
  EXPECT_DOUBLE_EQ(s.max_ms, 100.0);
  EXPECT_DOUBLE_EQ(s.mean_ms, 50.5);
}

TEST(LatencyStats, SmallListAndErrors) {
  const LatencyStats s = compute_latency_stats({5.0, 1.0, 3.0});
  EXPECT_DOUBLE_EQ(s.median_ms, 3.0);
  EXPECT_DOUBLE_EQ(s.p95_ms, 4.8);  // index 1.9: 3 + 0.9 * (5 - 3)
  EXPECT_DOUBLE_EQ(s.mean_ms, 3.0);
  EXPECT_THROW(compute_latency_stats({}), std::invalid_argument);
  EXPECT_THROW(compute_latency_stats({1.0, kNaN}), std::invalid_argument);
}

TEST(ModeTimeline, ModeAtTimeAndTimeFractions) {
  // Given out of order; RLM 0-10 s, ILM 10-40 s, RLM 40-50 s.
  const ModeTimeline modes({{40.0, kModeRlm}, {0.0, kModeRlm}, {10.0, kModeIlm}, {50.0, kModeRlm}});
  EXPECT_FALSE(modes.mode_at(-0.5).has_value());
  EXPECT_EQ(modes.mode_at(0.0), kModeRlm);
  EXPECT_EQ(modes.mode_at(9.99), kModeRlm);
  EXPECT_EQ(modes.mode_at(10.0), kModeIlm);
  EXPECT_EQ(modes.mode_at(45.0), kModeRlm);
  EXPECT_EQ(modes.mode_at(1e9), kModeRlm);
  const std::map<int, double> fractions = modes.time_fractions();
  ASSERT_EQ(fractions.size(), 2u);
  EXPECT_DOUBLE_EQ(fractions.at(kModeRlm), 0.4);
  EXPECT_DOUBLE_EQ(fractions.at(kModeIlm), 0.6);
}

TEST(ModeTimeline, NoSpanGivesNoFractions) {
  EXPECT_TRUE(ModeTimeline().time_fractions().empty());
  EXPECT_TRUE(ModeTimeline({{3.0, kModeIlm}}).time_fractions().empty());
  EXPECT_EQ(mode_name(kModeIlm), "ilm");
  EXPECT_EQ(mode_name(9), "mode_9");
}

TEST(JsonWriter, EscapesStrings) {
  EXPECT_EQ(JsonWriter::quote("a\"b\\c\nd\te\x01"), "\"a\\\"b\\\\c\\nd\\te\\u0001\"");
  EXPECT_EQ(JsonWriter::quote("\r\b\f"), "\"\\r\\b\\f\"");
  EXPECT_EQ(JsonWriter::quote("h\xC3\xA9"), "\"h\xC3\xA9\"");  // UTF-8 unchanged
}

TEST(JsonWriter, WritesNestedDocumentWithNanAsNull) {
  JsonWriter json;
  json.begin_object();
  json.key("name").string("run \"B\"");
  json.key("values").begin_array().number(0.1).number(kNaN).number(
      std::numeric_limits<double>::infinity());
  json.integer(-3).boolean(true).null().end_array();
  json.key("empty").begin_object().end_object();
  json.end_object();
  EXPECT_EQ(json.str(),
            "{\n"
            "  \"name\": \"run \\\"B\\\"\",\n"
            "  \"values\": [\n"
            "    0.1,\n"
            "    null,\n"
            "    null,\n"
            "    -3,\n"
            "    true,\n"
            "    null\n"
            "  ],\n"
            "  \"empty\": {}\n"
            "}\n");
}

TEST(JsonWriter, RejectsMalformedDocuments) {
  JsonWriter no_key;
  no_key.begin_object();
  EXPECT_THROW(no_key.number(1.0), std::logic_error);
  EXPECT_THROW(no_key.str(), std::logic_error);  // still open
  JsonWriter mismatched;
  mismatched.begin_array();
  EXPECT_THROW(mismatched.end_object(), std::logic_error);
  JsonWriter two_roots;
  two_roots.integer(1);
  EXPECT_THROW(two_roots.integer(2), std::logic_error);
}

EvalReport short_run_report() {
  const Trajectory gt = make_trajectory(51, 0.1, [](int k) {
    return translation({double(k), 0, 0});
  });
  EvalReport report;
  report.name = "session_b";
  report.metrics = evaluate_trajectory(gt, transformed(gt, translation({0, 0.5, 0})),
                                       with_alignment(AlignmentMode::kNone));
  return report;
}

TEST(EvalReport, JsonWritesMissingRpeAsNullAndOmitsAbsentParts) {
  EvalReport report = short_run_report();
  const std::string without = to_json(report);
  EXPECT_NE(without.find("\"rpe_translation_percent\": null"), std::string::npos) << without;
  EXPECT_NE(without.find("\"ate_position_rmse_m\": 0.5"), std::string::npos) << without;
  EXPECT_NE(without.find("RPE not computed"), std::string::npos);
  EXPECT_EQ(without.find("latency_ms"), std::string::npos);
  EXPECT_EQ(without.find("mode_time_fraction"), std::string::npos);

  report.latency = compute_latency_stats({10.0, 20.0});
  report.mode_time_fractions = {{kModeRlm, 0.25}, {kModeIlm, 0.75}};
  const std::string with = to_json(report);
  EXPECT_NE(with.find("\"median\": 15"), std::string::npos) << with;
  EXPECT_NE(with.find("\"ilm\": 0.75"), std::string::npos) << with;
}

int count_columns(const std::string& line) {
  return static_cast<int>(std::count(line.begin(), line.end(), '|')) - 1;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    lines.push_back(line);
  }
  return lines;
}

TEST(EvalReport, MarkdownTableHasHeaderSeparatorAndRows) {
  EvalReport plain = short_run_report();
  const std::vector<std::string> one = lines_of(markdown_table({plain}));
  ASSERT_EQ(one.size(), 3u);
  EXPECT_EQ(count_columns(one[0]), 12);
  EXPECT_EQ(count_columns(one[1]), 12);
  EXPECT_EQ(count_columns(one[2]), 12);
  EXPECT_NE(one[2].find("| session_b | none | 51 | 0 | 0.500 |"), std::string::npos) << one[2];
  EXPECT_NE(one[2].find("n/a"), std::string::npos);  // RPE of a 50 m run

  EvalReport timed = plain;
  timed.name = "timed";
  timed.latency = compute_latency_stats({1.0, 2.0, 3.0});
  const std::vector<std::string> two = lines_of(markdown_table({plain, timed}));
  ASSERT_EQ(two.size(), 4u);
  for (const std::string& line : two) {
    EXPECT_EQ(count_columns(line), 18) << line;
  }
  EXPECT_NE(two[0].find("p99 (ms)"), std::string::npos);
  EXPECT_NE(two[2].find("| - | - | - | - | - | - |"), std::string::npos) << two[2];
  EXPECT_NE(two[3].find("| 3 | 2.00 |"), std::string::npos) << two[3];
}

int count_pixels(const cv::Mat& image, const cv::Scalar& color) {
  const cv::Vec3b bgr(static_cast<uchar>(color[0]), static_cast<uchar>(color[1]),
                      static_cast<uchar>(color[2]));
  int n = 0;
  for (int r = 0; r < image.rows; ++r) {
    for (int c = 0; c < image.cols; ++c) {
      n += image.at<cv::Vec3b>(r, c) == bgr;
    }
  }
  return n;
}

TEST(TrajectoryPlot, DrawsEstimateInModeColours) {
  TrajectoryPlotInput input;
  input.ground_truth = wavy_ground_truth();
  // Off the ground truth by 15 m so that the lines do not cover each other.
  input.estimate = transformed(input.ground_truth, translation({0, 15, 0}));
  input.modes = ModeTimeline({{0.0, kModeRlm}, {25.0, kModeIlm}});
  input.mapped_area = make_trajectory(200, 0.1, [](int k) {
    return translation({double(k), 0, 0});
  });
  input.title = "session_b: ATE 0.1 m";
  TrajectoryPlotConfig config;
  config.width_px = 640;
  config.height_px = 480;
  const cv::Mat image = render_trajectory_plot(input, config);
  ASSERT_EQ(image.type(), CV_8UC3);
  EXPECT_EQ(image.cols, 640);
  EXPECT_EQ(image.rows, 480);
  EXPECT_GT(count_pixels(image, kRlmColor), 100);
  EXPECT_GT(count_pixels(image, kIlmColor), 100);
  EXPECT_GT(count_pixels(image, kGroundTruthColor), 100);
  EXPECT_EQ(count_pixels(image, kUnknownModeColor), 0);
  // The band is blended, so it is neither white nor its own colour.
  const int white = count_pixels(image, cv::Scalar(255, 255, 255));
  EXPECT_LT(white, 640 * 480 - 5000);

  input.modes = ModeTimeline();
  const cv::Mat unknown = render_trajectory_plot(input, config);
  EXPECT_GT(count_pixels(unknown, kUnknownModeColor), 100);
  EXPECT_EQ(count_pixels(unknown, kRlmColor), 0);
}

TEST(TrajectoryPlot, RejectsEmptyInputAndBadConfig) {
  EXPECT_THROW(render_trajectory_plot(TrajectoryPlotInput{}, TrajectoryPlotConfig{}),
               std::invalid_argument);
  TrajectoryPlotInput input;
  input.ground_truth = wavy_ground_truth();
  TrajectoryPlotConfig small;
  small.width_px = 120;
  EXPECT_THROW(render_trajectory_plot(input, small), std::invalid_argument);
}

}  // namespace
}  // namespace liloc::eval
