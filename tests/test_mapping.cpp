#include <gtest/gtest.h>

#include "mapping/central_session_builder.hpp"
#include "mapping/pose_graph_optimizer.hpp"
#include "math/so3.hpp"

namespace liloc {
namespace {

// A square drive with odometry drift in heading; one loop edge back to the start pulls the
// graph onto the truth.
TEST(PoseGraph, ALoopClosureRemovesOdometryDrift) {
  std::vector<MapKeyframe> truth, drifted;
  std::vector<PoseGraphEdge> edges;
  const int per_side = 10;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 4 * per_side; ++i) {
    MapKeyframe kf;
    kf.id = i;
    kf.T_map_body = T;
    truth.push_back(kf);
    const bool corner = (i + 1) % per_side == 0;
    T = T * se3::make(so3::exp(Eigen::Vector3d(0, 0, corner ? M_PI / 2 : 0)),
                      Eigen::Vector3d(corner ? 0 : 2, 0, 0));
  }
  Eigen::Isometry3d D = Eigen::Isometry3d::Identity();
  for (size_t i = 0; i < truth.size(); ++i) {
    if (i > 0) {
      const Eigen::Isometry3d step = truth[i - 1].T_map_body.inverse() * truth[i].T_map_body;
      PoseGraphEdge e;
      e.from = static_cast<int64_t>(i - 1);
      e.to = static_cast<int64_t>(i);
      e.T_from_to =
          step * se3::make(so3::exp(Eigen::Vector3d(0, 0, 0.01)), Eigen::Vector3d::Zero());
      e.information = Matrix6d::Identity() * 100.0;
      edges.push_back(e);
      D = D * e.T_from_to;
    }
    MapKeyframe kf = truth[i];
    kf.T_map_body = D;
    drifted.push_back(kf);
  }
  PoseGraphEdge loop;
  loop.from = 0;
  loop.to = static_cast<int64_t>(truth.size() - 1);
  loop.T_from_to = truth.front().T_map_body.inverse() * truth.back().T_map_body;
  loop.information = Matrix6d::Identity() * 1e4;
  loop.kind = PoseGraphEdge::Kind::kLoop;
  edges.push_back(loop);
  const double before =
      (drifted.back().T_map_body.translation() - truth.back().T_map_body.translation()).norm();
  const PoseGraphResult r = optimize_pose_graph(drifted, edges, PoseGraphConfig{});
  EXPECT_TRUE(r.converged);
  EXPECT_LT(r.final_cost, r.initial_cost);
  double worst = 0.0;
  for (size_t i = 0; i < truth.size(); ++i) {
    worst = std::max(
        worst, (drifted[i].T_map_body.translation() - truth[i].T_map_body.translation()).norm());
  }
  EXPECT_GT(before, 1.0);
  EXPECT_LT(worst, 0.5 * before);
  EXPECT_TRUE(drifted.front().T_map_body.isApprox(Eigen::Isometry3d::Identity()));
  PoseGraphEdge bad;
  bad.from = 0;
  bad.to = 999;
  EXPECT_THROW(optimize_pose_graph(drifted, {bad}, PoseGraphConfig{}), std::invalid_argument);
}

// Edge information is over the right perturbation of T_from_to: translation in the
// to-frame. Two edges measure one pose b, turned 90 degrees from a: the first is sure of
// b's own x (a's y), the second of b's own y (a's x). The optimum takes each coordinate
// from the edge that is sure of it; whitening in a's frame would take them crosswise.
TEST(PoseGraph, AnisotropicInformationIsInTheToFrame) {
  std::vector<MapKeyframe> keyframes(2);
  keyframes[0].id = 0;
  keyframes[1].id = 1;
  const Eigen::Matrix3d R_ab = so3::exp(Eigen::Vector3d(0, 0, M_PI / 2));
  keyframes[1].T_map_body = se3::make(R_ab, Eigen::Vector3d(1.2, 0.2, 0));
  Vector6d sure_of_x, sure_of_y;
  sure_of_x << 1e6, 1.0, 1e6, 1e6, 1e6, 1e6;
  sure_of_y << 1.0, 1e6, 1e6, 1e6, 1e6, 1e6;
  PoseGraphEdge first, second;
  first.from = second.from = 0;
  first.to = second.to = 1;
  first.T_from_to = se3::make(R_ab, Eigen::Vector3d(1.0, 0.5, 0));  // b's x is a's y: 0.5
  first.information = sure_of_x.asDiagonal();
  second.T_from_to = se3::make(R_ab, Eigen::Vector3d(2.0, -0.5, 0));  // b's y is -a's x: 2
  second.information = sure_of_y.asDiagonal();
  optimize_pose_graph(keyframes, {first, second}, PoseGraphConfig{});
  const Eigen::Vector3d p = keyframes[1].T_map_body.translation();
  EXPECT_NEAR(p.x(), 2.0, 1e-3) << p.transpose();
  EXPECT_NEAR(p.y(), 0.5, 1e-3) << p.transpose();
}

// A straight level drive whose odometry pitches up 1 mrad per keyframe after the tenth,
// no loops: the gravity factors, from the true down in each body, take the drift out of
// the map's attitude. Observations less certain than gravity_max_sigma_rad are left out.
TEST(PoseGraph, GravityLevelsAPitchDrift) {
  const int n = 40;
  std::vector<MapKeyframe> keyframes;
  std::vector<PoseGraphEdge> edges;
  std::vector<GravityObservation> gravity;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const Eigen::Isometry3d step_true = se3::make(Eigen::Matrix3d::Identity(), {1, 0, 0});
  for (int i = 0; i < n; ++i) {
    if (i > 0) {
      PoseGraphEdge e;
      e.from = i - 1;
      e.to = i;
      e.T_from_to = step_true * se3::make(so3::exp(Eigen::Vector3d(0, i > 10 ? -1e-3 : 0, 0)),
                                          Eigen::Vector3d::Zero());
      Vector6d information;
      information << Eigen::Vector3d::Constant(1e4), Eigen::Vector3d::Constant(2.5e5);
      e.information = information.asDiagonal();
      edges.push_back(e);
      T = T * e.T_from_to;
    }
    MapKeyframe kf;
    kf.id = i;
    kf.T_map_body = T;
    keyframes.push_back(kf);
    gravity.push_back({i, -Eigen::Vector3d::UnitZ(), i == 20 ? 0.01 : 0.0});
  }
  const auto pitch_between = [&](int a, int b) {
    return so3::log(keyframes[a].T_map_body.linear().transpose() * keyframes[b].T_map_body.linear())
        .norm();
  };
  EXPECT_NEAR(pitch_between(5, n - 1), 29e-3, 1e-6);
  const PoseGraphResult r = optimize_pose_graph(keyframes, edges, PoseGraphConfig{}, gravity);
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.gravity_factors, n - 2);  // not the anchor, not the one at 10 mrad
  EXPECT_GT(r.max_tilt_before_rad, 15e-3);
  // What is left is next to the held anchor, which is 11 mrad off the drive's mean down
  // (seen: 17.8 -> 4.3 mrad); beyond it the 29 mrad of drift are gone (seen: 0.7 mrad).
  EXPECT_LT(r.max_tilt_after_rad, 0.3 * r.max_tilt_before_rad);
  EXPECT_LT(pitch_between(5, n - 1), 2e-3);
  // The frame is turned so that the drive's down is -z (the drive is level): its mean down
  // was 11 mrad off the anchor's, whose frame the map had.
  EXPECT_NEAR(r.frame_turn_rad, 11e-3, 2e-3);
  for (int i = 5; i < n; ++i) {
    EXPECT_LT(so3::tilt(keyframes[i].T_map_body.linear()), 2e-3) << "keyframe " << i;
  }
  PoseGraphConfig off;
  off.level_by_gravity = false;
  std::vector<MapKeyframe> untouched = keyframes;
  EXPECT_EQ(optimize_pose_graph(untouched, edges, off, gravity).gravity_factors, 0);
  EXPECT_THROW(optimize_pose_graph(keyframes, edges, PoseGraphConfig{}, {{n, {0, 0, -1}, 0.0}}),
               std::invalid_argument);
}

// A straight 59 m drive with a keyframe per metre, loops off, levelled by gravity (level
// already): the keyframes keep their odometry poses, consecutive ones are linked with
// odometry edges, Eq. 2 closes a submap every 20 keyframes, and the clouds come out by
// keyframe id.
TEST(CentralSessionBuilder, KeyframesEdgesSubmapsAndClouds) {
  CentralSessionConfig config;
  config.close_loops = false;
  CentralSessionBuilder builder(config, SubmapConfig{}, PolarDescriptorConfig{});
  for (int i = 0; i < 60; ++i) {
    Keyframe kf;
    kf.utime_us = 1000000 * i;
    kf.T_odom_body.translation() = Eigen::Vector3d(i, 0.0, 0.0);
    kf.cloud_body.points.assign(static_cast<size_t>(i + 1), Eigen::Vector3f::UnitZ());
    kf.cloud_body.intensities.assign(static_cast<size_t>(i + 1), 1.0f);
    if (i != 7) {  // one keyframe without an IMU's gravity
      kf.gravity_body = -Eigen::Vector3d::UnitZ();
      kf.gravity_sigma_rad = 0.001;
    }
    builder.add(kf);
  }
  std::map<int64_t, PointCloud> clouds;
  CentralSessionReport report;
  const MapData map = builder.build(&clouds, &report);
  ASSERT_EQ(map.keyframes.size(), 60u);
  EXPECT_EQ(report.keyframes, 60u);
  EXPECT_EQ(report.loop_closures, 0u);
  EXPECT_EQ(report.graph.gravity_factors, 58);  // not the anchor
  ASSERT_EQ(map.edges.size(), 59u);
  for (const PoseGraphEdge& e : map.edges) {
    EXPECT_EQ(e.kind, PoseGraphEdge::Kind::kOdometry);
    EXPECT_EQ(e.to, e.from + 1);
    EXPECT_NEAR(e.T_from_to.translation().x(), 1.0, 1e-12);
  }
  for (const MapKeyframe& kf : map.keyframes) {
    EXPECT_EQ(kf.session, "A");
    EXPECT_NEAR(kf.T_map_body.translation().x(), static_cast<double>(kf.id), 1e-12);
    ASSERT_EQ(clouds.count(kf.id), 1u);
    EXPECT_EQ(clouds.at(kf.id).size(), static_cast<size_t>(kf.id + 1));
    EXPECT_GE(kf.submap_id, 0);
  }
  EXPECT_EQ(report.submaps, map.submaps.size());
  EXPECT_EQ(map.submaps.size(), 3u);
}

}  // namespace
}  // namespace liloc
