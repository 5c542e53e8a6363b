#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <vector>

#include "loop_closure/loop_closure.hpp"
#include "math/se3.hpp"
#include "pointcloud/voxel_grid.hpp"
#include "sim/lidar_model.hpp"
#include "sim/random.hpp"
#include "sim/vehicle_trajectory.hpp"
#include "sim/world_generator.hpp"

namespace liloc {
namespace {

constexpr double kDeg = 3.141592653589793 / 180.0;
constexpr int64_t kStartUs = 1748779200000000;

const sim::GeneratedWorld& campus() {
  static const sim::GeneratedWorld world = sim::generate_world(sim::WorldConfig{});
  return world;
}

// A VLP-16 sweep cast from a standing body pose (no motion distortion), with range noise,
// in the body frame and downsampled as the odometry's keyframes are (0.3 m).
PointCloud scan_from(const Eigen::Isometry3d& T_world_body, uint64_t seed) {
  static const sim::LidarSpec spec = sim::lidar_spec("vlp16");
  static const std::vector<sim::LidarRay> rays = sim::sweep_rays(spec, 0);
  const Eigen::Isometry3d T_body_lidar(Eigen::Translation3d(0.05, 0.0, 0.35));
  const Eigen::Isometry3d T_world_lidar = T_world_body * T_body_lidar;
  sim::RaycastScratch scratch;
  sim::Random rng(seed);
  PointCloud cloud;
  for (const sim::LidarRay& ray : rays) {
    const Eigen::Vector3d dir = T_world_lidar.linear() * ray.direction.cast<double>();
    const double noise = rng.normal(0.0, spec.range_noise_m);
    const auto hit =
        campus().world.raycast(T_world_lidar.translation(), dir, spec.max_range_m, scratch);
    if (!hit || hit->range_m < 1.5) {
      continue;
    }
    const Eigen::Vector3d p_lidar = ray.direction.cast<double>() * (hit->range_m + noise);
    cloud.push_back((T_body_lidar * p_lidar).cast<float>(), 0.0f);
  }
  return voxel_downsample(cloud, 0.3f);
}

// Keyframes every metre of a drive once around a campus block (~270 m, 4 corners) and
// down its first street again: true poses, times and clouds.
struct Drive {
  std::vector<Eigen::Isometry3d> truth;  // T_world_body
  std::vector<int64_t> utime_us;
  std::vector<PointCloud> clouds;
};

const Drive& block_drive() {
  static const Drive drive = [] {
    const std::vector<Eigen::Vector2d>& nodes = campus().world.roads().nodes();
    const sim::VehicleTrajectory trajectory(
        campus().world, {nodes[0], nodes[1], nodes[6], nodes[5], nodes[0], nodes[1]},
        sim::MotionConfig{}, 11);
    Drive d;
    Eigen::Vector3d last(1e9, 0.0, 0.0);
    for (double t = 0.0; t <= trajectory.duration_s(); t += 0.01) {
      const Eigen::Isometry3d T = trajectory.pose(t);
      if ((T.translation() - last).norm() >= 1.0) {
        last = T.translation();
        d.truth.push_back(T);
        d.utime_us.push_back(kStartUs + static_cast<int64_t>(std::llround(t * 1e6)));
        d.clouds.push_back(scan_from(T, d.clouds.size()));
      }
    }
    return d;
  }();
  return drive;
}

// Odometry estimates: the true motion between keyframes with a drift of 0.1 % in scale
// and 5e-5 rad/m in heading (~0.3 % of the distance around the block).
std::vector<Eigen::Isometry3d> with_drift(const std::vector<Eigen::Isometry3d>& truth) {
  std::vector<Eigen::Isometry3d> odom = {truth.front()};
  for (size_t k = 1; k < truth.size(); ++k) {
    const Eigen::Isometry3d step = truth[k - 1].inverse() * truth[k];
    const double length = step.translation().norm();
    Vector6d drift;
    drift << 1e-3 * step.translation(), 0.0, 0.0, 5e-5 * length;
    odom.push_back(odom.back() * step * se3::exp(drift));
  }
  return odom;
}

MapKeyframe keyframe(int64_t id, int64_t utime_us, const Eigen::Isometry3d& T_map_body) {
  MapKeyframe k;
  k.id = id;
  k.utime_us = utime_us;
  k.session = "A";
  k.T_map_body = T_map_body;
  return k;
}

struct PoseError {
  double translation_m;
  double rotation_deg;
};
PoseError error(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
  const Eigen::Isometry3d e = truth.inverse() * estimate;
  return {e.translation().norm(), se3::rotation_angle(e) / kDeg};
}

// The first `count` keyframes of the block drive (a straight street), odometry = truth.
void add_street(LoopClosureDetector& detector, int count) {
  const Drive& d = block_drive();
  for (int k = 0; k < count; ++k) {
    EXPECT_TRUE(detector.add(keyframe(k, d.utime_us[k], d.truth[k]), d.clouds[k]).empty());
  }
}

// A keyframe of the street seen again a minute later from 0.8 m ahead, 1.5 m to the
// left and turned by 10 deg; the odometry's estimate is off by 0.3 m and 0.4 deg.
struct Revisit {
  Eigen::Isometry3d truth;
  Eigen::Isometry3d odom;
  PointCloud cloud;
};
Revisit revisit_of(int k, double heading_error_deg) {
  const Drive& d = block_drive();
  Revisit r;
  Vector6d offset, odom_error;
  offset << 0.8, 1.5, 0.0, 0.0, 0.0, 10.0 * kDeg;
  odom_error << 0.2, -0.2, 0.05, 0.0, 0.0, (0.4 + heading_error_deg) * kDeg;
  r.truth = d.truth[k] * se3::exp(offset);
  r.odom = r.truth * se3::exp(odom_error);
  r.cloud = scan_from(r.truth, 1000);
  return r;
}

TEST(LoopClosure, RecognizesAKeyframeSeenAgainFromAKnownOffset) {
  const Drive& d = block_drive();
  LoopClosureDetector detector{LoopClosureConfig{}};
  add_street(detector, 60);
  const Revisit r = revisit_of(30, 0.0);
  const std::vector<LoopClosure> closures =
      detector.add(keyframe(1000, d.utime_us[59] + 60000000, r.odom), r.cloud);
  ASSERT_EQ(closures.size(), 1u) << "tried " << detector.stats().tried;
  const LoopClosure& c = closures.front();
  EXPECT_EQ(c.to_id, 1000);
  EXPECT_NEAR(c.from_id, 30, 10);
  const PoseError e = error(c.T_from_to, d.truth[c.from_id].inverse() * r.truth);
  EXPECT_LT(e.translation_m, 0.02);
  EXPECT_LT(e.rotation_deg, 0.2);
  // The odometry was off by more than that: the closure corrects it.
  EXPECT_GT(error(d.truth[c.from_id].inverse() * r.odom, d.truth[c.from_id].inverse() * r.truth)
                .translation_m,
            0.25);
  EXPECT_LT(c.fitness_m, 0.08);
  EXPECT_LT(c.descriptor_distance, 0.35);
  // Information: symmetric positive definite, no tighter than the target map's own
  // consistency (2 cm, 0.002 rad) and not vague either.
  EXPECT_TRUE(c.information.isApprox(c.information.transpose()));
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(c.information);
  EXPECT_GT(eig.eigenvalues().minCoeff(), 0.0);
  const Vector6d sigma = c.information.inverse().diagonal().cwiseSqrt();
  for (int i = 0; i < 3; ++i) {
    EXPECT_GE(sigma(i), 0.02);
    EXPECT_LT(sigma(i), 0.05);
    EXPECT_GE(sigma(3 + i), 0.002);
    EXPECT_LT(sigma(3 + i), 0.005);
  }
  EXPECT_EQ(detector.stats().verified, 1);
  EXPECT_EQ(detector.stats().yaw_refined, 0);
}

// The odometry's heading off by 12 deg (two sectors): the descriptor's yaw gives the
// start, and the registration finds the true pose. The default bound calls a 12 deg
// correction over a ~60 m path implausible; a looser one lets it through.
TEST(LoopClosure, DescriptorYawRefinesADriftedHeadingWithinThePlausibilityBound) {
  const Drive& d = block_drive();
  const Revisit r = revisit_of(30, 12.0);
  const MapKeyframe query = keyframe(1000, d.utime_us[59] + 60000000, r.odom);

  LoopClosureDetector strict{LoopClosureConfig{}};
  add_street(strict, 60);
  EXPECT_TRUE(strict.add(query, r.cloud).empty());
  EXPECT_GE(strict.stats().rejected_implausible, 1);
  EXPECT_GE(strict.stats().yaw_refined, 1);

  LoopClosureConfig loose;
  loose.correction_floor_rad = 0.3;
  LoopClosureDetector detector(loose);
  add_street(detector, 60);
  const std::vector<LoopClosure> closures = detector.add(query, r.cloud);
  ASSERT_EQ(closures.size(), 1u);
  const LoopClosure& c = closures.front();
  const PoseError e = error(c.T_from_to, d.truth[c.from_id].inverse() * r.truth);
  EXPECT_LT(e.translation_m, 0.02);
  EXPECT_LT(e.rotation_deg, 0.2);
  EXPECT_EQ(detector.stats().yaw_refined, 1);
}

// The odometry believes it is back on the street, but the clouds are from elsewhere on
// the block: nothing is accepted, by the descriptor and, with its gate open, by the
// verification alone.
TEST(LoopClosure, NoClosureBetweenDifferentPlaces) {
  const Drive& d = block_drive();
  LoopClosureConfig open_gate;
  open_gate.max_descriptor_distance = 1.0;
  for (const LoopClosureConfig& config : {LoopClosureConfig{}, open_gate}) {
    LoopClosureDetector detector(config);
    add_street(detector, 60);
    int64_t id = 1000;
    for (size_t k = 100; k < 250; k += 10) {
      ASSERT_GT((d.truth[k].translation() - d.truth[30].translation()).norm(), 40.0);
      const MapKeyframe query =
          keyframe(id, d.utime_us[59] + 60000000 + id * 200000, d.truth[20 + id % 20]);
      EXPECT_TRUE(detector.add(query, d.clouds[k]).empty()) << "cloud of keyframe " << k;
      ++id;
    }
    const LoopClosureStats& s = detector.stats();
    EXPECT_GT(s.nearby, 0);
    EXPECT_EQ(s.verified, 0);
    EXPECT_EQ(s.tried, s.rejected_correspondences + s.rejected_degenerate + s.rejected_fitness +
                           s.rejected_implausible);
    if (config.max_descriptor_distance < 1.0) {
      EXPECT_EQ(s.rejected_descriptor, s.nearby);
    } else {
      EXPECT_EQ(s.tried, 15);
    }
  }
}

// Closures need min_time_gap_s: the street itself (seconds apart) never closes, nor does
// the same view 14.5 s later; 40 s later it does.
TEST(LoopClosure, NoClosureToTheImmediatePast) {
  const Drive& d = block_drive();
  LoopClosureDetector detector{LoopClosureConfig{}};
  add_street(detector, 60);
  EXPECT_EQ(detector.stats().nearby, 0);
  EXPECT_TRUE(
      detector.add(keyframe(1000, d.utime_us[30] + 14500000, d.truth[30]), d.clouds[30]).empty());
  EXPECT_EQ(detector.stats().nearby, 0);
  const std::vector<LoopClosure> later =
      detector.add(keyframe(1001, d.utime_us[30] + 40000000, d.truth[30]), d.clouds[30]);
  ASSERT_EQ(later.size(), 1u);
  EXPECT_EQ(later.front().from_id, 30);
  EXPECT_LT(later.front().descriptor_distance, 1e-9);
  EXPECT_LT(error(later.front().T_from_to, Eigen::Isometry3d::Identity()).translation_m, 0.01);
}

struct LoopRun {
  std::vector<LoopClosure> closures;
  LoopClosureStats stats;
};

LoopRun run_around_the_block() {
  const Drive& d = block_drive();
  const std::vector<Eigen::Isometry3d> odom = with_drift(d.truth);
  LoopClosureDetector detector{LoopClosureConfig{}};
  LoopRun run;
  for (size_t k = 0; k < d.clouds.size(); ++k) {
    for (const LoopClosure& c :
         detector.add(keyframe(static_cast<int64_t>(k), d.utime_us[k], odom[k]), d.clouds[k])) {
      run.closures.push_back(c);
    }
  }
  run.stats = detector.stats();
  return run;
}

const LoopRun& around_the_block() {
  static const LoopRun run = run_around_the_block();
  return run;
}

// Around the block with drifting odometry: where the drive comes back to its first
// street, keyframes close to the first ones, every closure with the true relative pose.
TEST(LoopClosure, ClosesTheBlockWithTheTrueRelativePoses) {
  const Drive& d = block_drive();
  const std::vector<Eigen::Isometry3d> odom = with_drift(d.truth);
  const PoseError drift = error(odom.back(), d.truth.back());
  EXPECT_GT(drift.translation_m, 0.5);
  const LoopRun& run = around_the_block();
  double worst_m = 0.0, worst_deg = 0.0;
  for (const LoopClosure& c : run.closures) {
    EXPECT_LT(c.from_id, 80);  // the first street ...
    EXPECT_GT(c.to_id, 250);   // ... driven again
    const PoseError e = error(c.T_from_to, d.truth[c.from_id].inverse() * d.truth[c.to_id]);
    worst_m = std::max(worst_m, e.translation_m);
    worst_deg = std::max(worst_deg, e.rotation_deg);
  }
  const LoopClosureStats& s = run.stats;
  std::printf(
      "%zu keyframes, drift %.2f m, %zu closures (worst %.3f m, %.3f deg); nearby %ld, "
      "descriptor-rejected %ld, tried %ld, rejected: correspondences %ld degenerate %ld "
      "fitness %ld implausible %ld; descriptor %.2f ms per keyframe, verification %.1f ms per "
      "candidate\n",
      d.clouds.size(), drift.translation_m, run.closures.size(), worst_m, worst_deg,
      static_cast<long>(s.nearby), static_cast<long>(s.rejected_descriptor),
      static_cast<long>(s.tried), static_cast<long>(s.rejected_correspondences),
      static_cast<long>(s.rejected_degenerate), static_cast<long>(s.rejected_fitness),
      static_cast<long>(s.rejected_implausible), s.descriptor_ms / s.keyframes,
      s.tried > 0 ? s.verification_ms / s.tried : 0.0);
  EXPECT_GE(run.closures.size(), 5u);
  EXPECT_LT(worst_m, 0.02);
  EXPECT_LT(worst_deg, 0.2);
}

TEST(LoopClosure, IsDeterministic) {
  const LoopRun& a = around_the_block();
  const LoopRun b = run_around_the_block();
  ASSERT_EQ(a.closures.size(), b.closures.size());
  ASSERT_FALSE(a.closures.empty());
  for (size_t i = 0; i < a.closures.size(); ++i) {
    EXPECT_EQ(a.closures[i].from_id, b.closures[i].from_id);
    EXPECT_EQ(a.closures[i].to_id, b.closures[i].to_id);
    EXPECT_EQ(a.closures[i].T_from_to.matrix(), b.closures[i].T_from_to.matrix());
    EXPECT_EQ(a.closures[i].information, b.closures[i].information);
    EXPECT_EQ(a.closures[i].fitness_m, b.closures[i].fitness_m);
  }
  EXPECT_EQ(a.stats.tried, b.stats.tried);
}

TEST(LoopClosure, RefusesKeyframesOutOfOrderAndBadConfigurations) {
  const Drive& d = block_drive();
  LoopClosureDetector detector{LoopClosureConfig{}};
  detector.add(keyframe(5, d.utime_us[5], d.truth[5]), d.clouds[5]);
  EXPECT_THROW(detector.add(keyframe(6, d.utime_us[4], d.truth[4]), d.clouds[4]),
               std::invalid_argument);
  EXPECT_THROW(detector.add(keyframe(5, d.utime_us[6], d.truth[6]), d.clouds[6]),
               std::invalid_argument);
  EXPECT_EQ(detector.num_keyframes(), 1u);

  LoopClosureConfig c;
  c.search_radius_m = 0.0;
  EXPECT_THROW(LoopClosureDetector{c}, std::invalid_argument);
  c = LoopClosureConfig{};
  c.max_descriptor_distance = 1.5;
  EXPECT_THROW(c.validate(), std::invalid_argument);
  c = LoopClosureConfig{};
  c.candidates = 0;
  EXPECT_THROW(c.validate(), std::invalid_argument);
  c = LoopClosureConfig{};
  c.registration.point_sigma_m = 0.0;
  EXPECT_THROW(c.validate(), std::invalid_argument);
  PolarDescriptorConfig descriptor;
  descriptor.sectors = 1;
  EXPECT_THROW(LoopClosureDetector(LoopClosureConfig{}, descriptor), std::invalid_argument);
  EXPECT_NO_THROW(LoopClosureConfig{}.validate());
}

}  // namespace
}  // namespace liloc
