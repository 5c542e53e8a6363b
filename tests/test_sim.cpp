#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "math/so3.hpp"
#include "sim/lidar_model.hpp"
#include "sim/session_planner.hpp"
#include "sim/session_simulator.hpp"
#include "sim/simulation_config.hpp"
#include "sim/world_generator.hpp"

namespace liloc::sim {
namespace {

// A flat 100 m x 100 m world with a straight road along x and the given objects.
World flat_world(std::vector<WorldObject> objects) {
  Heightfield g;
  g.origin_x_m = -50;
  g.origin_y_m = -50;
  g.resolution_m = 1.0;
  g.nx = 101;
  g.ny = 101;
  g.heights_m.assign(101 * 101, 0.0f);
  g.reflectivity.assign(100 * 100, 0.2f);
  RoadNetwork roads({{-40, 0}, {40, 0}}, {{0, 1}}, 10.0, 0.0);
  return World(g, std::move(objects), roads,
               Eigen::AlignedBox2d(Eigen::Vector2d(-50, -50), Eigen::Vector2d(50, 50)), 4.0);
}

WorldObject single(Primitive p, ObjectClass c = ObjectClass::kBuilding) {
  WorldObject o;
  o.object_class = c;
  o.primitives.push_back(p);
  return o;
}

TEST(World, RaycastHitsBoxCylinderAndGround) {
  Primitive wall;
  wall.center = Eigen::Vector3d(20, 0, 2);
  wall.half_size = Eigen::Vector3d(0.5, 5, 2);
  Primitive pole;
  pole.shape = Primitive::Shape::kCylinder;
  pole.center = Eigen::Vector3d(0, 10, 3);
  pole.half_size = Eigen::Vector3d(0.2, 0.2, 3);
  std::vector<WorldObject> objects = {single(wall), single(pole)};
  objects[1].id = 1;
  const World world = flat_world(objects);
  RaycastScratch scratch;
  const Eigen::Vector3d o(0, 0, 1.5);
  auto hit = world.raycast(o, Eigen::Vector3d::UnitX(), 100, scratch);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->range_m, 19.5, 1e-9);
  EXPECT_TRUE(hit->normal.isApprox(Eigen::Vector3d(-1, 0, 0)));
  hit = world.raycast(o, Eigen::Vector3d::UnitY(), 100, scratch);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->range_m, 9.8, 1e-9);
  EXPECT_EQ(hit->object_id, 1u);
  const Eigen::Vector3d down = Eigen::Vector3d(1, 1, -1).normalized();
  hit = world.raycast(o, down, 100, scratch);
  ASSERT_TRUE(hit);
  EXPECT_EQ(hit->object_id, World::kGroundId);
  EXPECT_NEAR((o + hit->range_m * down).z(), 0.0, 1e-9);
  EXPECT_FALSE(world.raycast(o, Eigen::Vector3d(-1, 0, 0.5).normalized(), 100, scratch));
}

TEST(World, YawedBoxAndRangeLimit) {
  Primitive b;
  b.center = Eigen::Vector3d(10, 0, 1);
  b.half_size = Eigen::Vector3d(1, 1, 1);
  b.yaw_rad = M_PI / 4;  // a diamond seen from the origin: nearest corner at 10 - sqrt(2)
  const World world = flat_world({single(b)});
  RaycastScratch scratch;
  auto hit = world.raycast(Eigen::Vector3d(0, 0, 1), Eigen::Vector3d::UnitX(), 100, scratch);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->range_m, 10 - std::sqrt(2.0), 1e-9);
  EXPECT_FALSE(world.raycast(Eigen::Vector3d(0, 0, 1), Eigen::Vector3d::UnitX(), 5, scratch));
}

World tree_world() {
  Primitive crown;
  crown.shape = Primitive::Shape::kFoliage;
  crown.center = Eigen::Vector3d(10, 0, 5);
  crown.half_size = Eigen::Vector3d(2, 2, 2);
  crown.density_per_m = 0.5f;
  return flat_world({single(crown, ObjectClass::kTree)});
}

// Foliage stops a ray with probability close to 1 - exp(-density * path length).
TEST(World, FoliageTransmittanceFollowsDensity) {
  const World world = tree_world();
  RaycastScratch scratch;
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-0.8, 0.8);
  double hits = 0.0, expected = 0.0;
  const int n = 4000;
  const Eigen::Vector3d center(10, 0, 5);
  for (int i = 0; i < n; ++i) {
    // Rays from around the origin in random directions through the (spherical, r = 2 m)
    // crown, each through other leaves.
    const Eigen::Vector3d origin(0, u(rng), 5 + u(rng));
    const Eigen::Vector3d target = center + Eigen::Vector3d(u(rng), u(rng), u(rng));
    const Eigen::Vector3d dir = (target - origin).normalized();
    const double d2 = ((center - origin) - (center - origin).dot(dir) * dir).squaredNorm();
    expected += 1.0 - std::exp(-0.5 * 2.0 * std::sqrt(4.0 - d2));
    const auto hit = world.raycast(origin, dir, 30, scratch);
    if (hit && hit->object_id == 0) {
      hits += 1.0;
      EXPECT_LE((origin + hit->range_m * dir - center).norm(), 2.0 + 1e-6);
    }
  }
  EXPECT_NEAR(hits / n, expected / n, 0.05);
}

// Leaves are fixed in the world: a ray from elsewhere aimed at a leaf hit reaches it (or
// an earlier leaf), never passes through it. Returns do not depend on the viewpoint.
TEST(World, FoliageLeavesAreTheSameFromEveryViewpoint) {
  const World world = tree_world();
  RaycastScratch scratch;
  int checked = 0;
  for (int i = 0; i < 400; ++i) {
    const double angle = -0.15 + 0.3 * i / 400.0;
    const Eigen::Vector3d o1(0, 0, 5.1);
    const auto first =
        world.raycast(o1, Eigen::Vector3d(std::cos(angle), std::sin(angle), 0), 30, scratch);
    if (!first || first->object_id != 0) {
      continue;
    }
    const Eigen::Vector3d leaf =
        o1 + first->range_m * Eigen::Vector3d(std::cos(angle), std::sin(angle), 0);
    const Eigen::Vector3d o2(1.0, -2.0, 5.5);
    const auto second = world.raycast(o2, (leaf - o2).normalized(), 30, scratch);
    ASSERT_TRUE(second);
    EXPECT_LE(second->range_m, (leaf - o2).norm() + 1e-6);
    ++checked;
  }
  EXPECT_GT(checked, 100);
}

TEST(World, CampusIsDeterministicInItsSeed) {
  WorldConfig config;
  const GeneratedWorld a = generate_world(config);
  const GeneratedWorld b = generate_world(config);
  config.seed = 2;
  const GeneratedWorld c = generate_world(config);
  EXPECT_EQ(a.world.num_primitives(), b.world.num_primitives());
  EXPECT_NE(a.world.num_primitives(), c.world.num_primitives());
  RaycastScratch s1, s2;
  for (int i = 0; i < 100; ++i) {
    const double angle = i * 0.0628;
    const Eigen::Vector3d dir(std::cos(angle), std::sin(angle), -0.05);
    const auto ha = a.world.raycast(Eigen::Vector3d(150, 150, 2), dir.normalized(), 100, s1);
    const auto hb = b.world.raycast(Eigen::Vector3d(150, 150, 2), dir.normalized(), 100, s2);
    ASSERT_EQ(ha.has_value(), hb.has_value());
    if (ha) {
      EXPECT_EQ(ha->range_m, hb->range_m);
    }
  }
  EXPECT_GT(a.world.objects().size(), 300u);
}

// The campus world and a short central session through it, shared by the tests below.
struct Campus {
  GeneratedWorld generated = generate_world(WorldConfig{});
  SessionPlan plan;
  Campus() {
    SessionPlanConfig lengths;
    lengths.a_length_m = 300.0;
    plan = plan_session("A", generated.world, generated.mapped_max_x_m, lengths, 42);
  }
};

const Campus& campus() {
  static const Campus c;
  return c;
}

// Trapezoidal strapdown integration, exact for linearly varying acceleration.
struct Integrated {
  Eigen::Matrix3d R;
  Eigen::Vector3d p, v;
};

Integrated integrate(const VehicleState& start, const std::vector<ImuSample>& samples,
                     const Eigen::Vector3d& ba, const Eigen::Vector3d& bg, double gravity) {
  Integrated s{start.T_world_body.linear(), start.T_world_body.translation(), start.velocity_world};
  const Eigen::Vector3d g(0, 0, -gravity);
  for (size_t k = 0; k + 1 < samples.size(); ++k) {
    const double dt = (samples[k + 1].utime_us - samples[k].utime_us) * 1e-6;
    const Eigen::Vector3d a0 = s.R * (samples[k].accel_mps2 - ba) + g;
    const Eigen::Matrix3d R1 =
        s.R * so3::exp(0.5 * (samples[k].gyro_rps + samples[k + 1].gyro_rps - 2 * bg) * dt);
    const Eigen::Vector3d a1 = R1 * (samples[k + 1].accel_mps2 - ba) + g;
    s.p += s.v * dt + (a0 / 3 + a1 / 6) * dt * dt;
    s.v += 0.5 * (a0 + a1) * dt;
    s.R = R1;
  }
  return s;
}

// Samples of [t0, t0 + duration] from a fresh simulator.
std::vector<ImuSample> imu_window(const VehicleTrajectory& trajectory, const ImuConfig& config,
                                  uint64_t seed, double t0, double duration,
                                  Eigen::Vector3d* ba = nullptr, Eigen::Vector3d* bg = nullptr) {
  ImuSimulator imu(trajectory, config, seed, 0);
  std::vector<ImuSample> out;
  while (imu.next_time_s() <= t0 + duration + 1e-9) {
    const bool inside = imu.next_time_s() >= t0 - 1e-9;
    const ImuSample s = imu.next();
    if (inside) {
      if (out.empty() && ba != nullptr) {
        *ba = imu.accel_bias();
        *bg = imu.gyro_bias();
      }
      out.push_back(s);
    }
  }
  return out;
}

TEST(Imu, NoiseFreeSamplesIntegrateBackToTheTrajectory) {
  const Campus& c = campus();
  const VehicleTrajectory trajectory(c.generated.world, c.plan.waypoints, MotionConfig{}, 7);
  ImuConfig config;
  config.accel_noise_density = config.gyro_noise_density = 0.0;
  config.accel_bias_random_walk = config.gyro_bias_random_walk = 0.0;
  config.initial_accel_bias_sigma_mps2 = config.initial_gyro_bias_sigma_rps = 0.0;
  const double t0 = 10.0;
  const std::vector<ImuSample> samples = imu_window(trajectory, config, 1, t0, 10.0);
  const Integrated end = integrate(trajectory.state(t0), samples, Eigen::Vector3d::Zero(),
                                   Eigen::Vector3d::Zero(), config.gravity_mps2);
  const Eigen::Isometry3d truth = trajectory.pose(t0 + 10.0);
  EXPECT_GT((truth.translation() - trajectory.pose(t0).translation()).norm(), 40.0)
      << "the window must contain real motion";
  EXPECT_LT((end.p - truth.translation()).norm(), 0.02);
  EXPECT_LT(so3::log(truth.linear().transpose() * end.R).norm(), 1e-4);
}

// With noise, the drift over 10 s matches what the noise densities predict: per horizontal
// axis sigma_p^2 = sigma_a^2 T^3 / 3 + g^2 sigma_g^2 T^5 / 20 (+ small bias-walk terms).
TEST(Imu, NoisyDriftMatchesTheNoiseModel) {
  const Campus& c = campus();
  const VehicleTrajectory trajectory(c.generated.world, c.plan.waypoints, MotionConfig{}, 7);
  const ImuConfig config;
  const double T = 10.0, t0 = 10.0, g = config.gravity_mps2;
  const double var_h = std::pow(config.accel_noise_density, 2) * std::pow(T, 3) / 3 +
                       g * g * std::pow(config.gyro_noise_density, 2) * std::pow(T, 5) / 20 +
                       std::pow(config.accel_bias_random_walk, 2) * std::pow(T, 5) / 20 +
                       g * g * std::pow(config.gyro_bias_random_walk, 2) * std::pow(T, 7) / 252;
  double sum_sq = 0.0;
  const int runs = 40;
  for (int seed = 0; seed < runs; ++seed) {
    Eigen::Vector3d ba, bg;
    const std::vector<ImuSample> samples =
        imu_window(trajectory, config, 100 + seed, t0, T, &ba, &bg);
    // The biases at the start are known (as in a filter that estimated them); the walk is not.
    const Integrated end = integrate(trajectory.state(t0), samples, ba, bg, g);
    const Eigen::Vector3d err = end.p - trajectory.pose(t0 + T).translation();
    sum_sq += err.x() * err.x() + err.y() * err.y();
  }
  const double rms_per_axis = std::sqrt(sum_sq / (2 * runs));
  const double predicted = std::sqrt(var_h);
  EXPECT_GT(rms_per_axis, 0.6 * predicted) << "predicted " << predicted;
  EXPECT_LT(rms_per_axis, 1.5 * predicted) << "predicted " << predicted;
}

TEST(Lidar, ScanFromTheTruePoseLiesOnTheWorldsSurfaces) {
  const Campus& c = campus();
  const VehicleTrajectory trajectory(c.generated.world, c.plan.waypoints, MotionConfig{}, 7);
  RigConfig rig_config;
  rig_config.lidar_rpy_deg = Eigen::Vector3d(1.0, -2.0, 90.0);  // a non-trivial extrinsic
  const SensorRig rig = rig_config.rig();
  const LidarSpec spec = lidar_spec("hdl32");
  const SessionSimulator sim(c.generated.world, trajectory, spec, rig, ImuConfig{}, 3, 0);
  RaycastScratch scratch;
  const LidarScan scan = sim.simulate_sweep(150, scratch);  // 15 s in: moving
  ASSERT_GT(scan.points.size(), 30000u);
  int within = 0;
  for (const LidarPoint& p : scan.points) {
    const double t = scan.utime_us * 1e-6 + p.time_offset_s;
    const Eigen::Vector3d world_point =
        trajectory.pose(t) * rig.T_body_lidar * p.position_m.cast<double>();
    if (c.generated.world.distance_to_surface(world_point) < 4 * spec.range_noise_m + 0.01) {
      ++within;
    }
  }
  EXPECT_GT(static_cast<double>(within) / scan.points.size(), 0.995);
}

// Driving at a wall, a sweep deskewed with the sweep-start pose misplaces each point by the
// distance driven until it was measured: the distortion the motion predicts.
TEST(Lidar, PerPointTimesCarryTheMotionDistortion) {
  Primitive wall;
  wall.center = Eigen::Vector3d(48, 0, 3);
  wall.half_size = Eigen::Vector3d(1, 45, 3);
  const World world = flat_world({single(wall)});
  MotionConfig motion;
  motion.cruise_speed_mps = 9.0;
  motion.speed_variation = 0.0;
  const VehicleTrajectory trajectory(world, {{-40, 0}, {40, 0}}, motion, 1);
  const LidarSpec spec = lidar_spec("vlp16");
  const SessionSimulator sim(world, trajectory, spec, SensorRig{}, ImuConfig{}, 5, 0);
  const int64_t sweep = 110;  // 11 s: near top speed
  const double t0 = sweep * spec.scan_period_s;
  const double speed = trajectory.state(t0).velocity_world.norm();
  ASSERT_GT(speed, 6.5);
  RaycastScratch scratch;
  const LidarScan scan = sim.simulate_sweep(sweep, scratch);
  const Eigen::Isometry3d start_pose = trajectory.pose(t0);
  int wall_points = 0;
  double max_time = 0.0, min_time = 1.0;
  for (const LidarPoint& p : scan.points) {
    const Eigen::Vector3d own = trajectory.pose(t0 + p.time_offset_s) * p.position_m.cast<double>();
    if (std::abs(own.x() - 47.0) > 0.2) {
      continue;  // not the wall's face
    }
    ++wall_points;
    const Eigen::Vector3d skewed = start_pose * p.position_m.cast<double>();
    const double driven =
        trajectory.pose(t0 + p.time_offset_s).translation().x() - start_pose.translation().x();
    EXPECT_NEAR(47.0 - skewed.x(), driven, 4 * spec.range_noise_m + 0.01);
    max_time = std::max(max_time, static_cast<double>(p.time_offset_s));
    min_time = std::min(min_time, static_cast<double>(p.time_offset_s));
  }
  EXPECT_GT(wall_points, 200);
  EXPECT_GT((max_time - min_time) * speed, 0.1) << "the wall spans enough of the sweep";
}

// A miscalibrated unit (the driver's nominal beam angles, the true ones off by the unit's
// errors, a range bias per beam) standing on flat ground: each downward ring sees the
// ground at the height its drawn elevation and range errors predict (flat ground cannot
// show an azimuth error), and a unit drawn with the same seed has the same errors in every
// session.
TEST(Lidar, BeamCalibrationErrorsMoveEachRingAsItsErrorsPredict) {
  const World world = flat_world({});
  const VehicleTrajectory trajectory(world, {{-40, 0}, {40, 0}}, MotionConfig{}, 1);
  const LidarSpec spec = lidar_spec("hdl32");
  RigConfig rig_config;
  rig_config.beam_range_bias_sigma_m = 0.03;
  rig_config.beam_elevation_sigma_deg = 0.2;
  rig_config.beam_azimuth_sigma_deg = 0.2;
  const SensorRig rig = rig_config.rig();
  const std::vector<BeamError> errors = draw_beam_errors(spec, rig.beam_errors);
  ASSERT_EQ(errors.size(), spec.elevations_rad.size());
  RigConfig other_unit = rig_config;
  other_unit.beam_error_seed = 2;
  EXPECT_NE(draw_beam_errors(spec, other_unit.rig().beam_errors)[0].elevation_rad,
            errors[0].elevation_rad);
  EXPECT_EQ(draw_beam_errors(spec, rig.beam_errors)[5].range_bias_m, errors[5].range_bias_m);
  EXPECT_TRUE(draw_beam_errors(spec, SensorRig{}.beam_errors).empty());

  // Ground height seen by each ring, per unit: the median world z of its points.
  const auto ring_heights = [&](const SensorRig& unit) {
    const SessionSimulator sim(world, trajectory, spec, unit, ImuConfig{}, 3, 0);
    RaycastScratch scratch;
    const LidarScan scan = sim.simulate_sweep(5, scratch);  // standing still at the start
    std::vector<std::vector<double>> z(spec.elevations_rad.size());
    const Eigen::Isometry3d T_world_lidar = trajectory.pose(0.5) * unit.T_body_lidar;
    for (const LidarPoint& p : scan.points) {
      z[p.ring].push_back((T_world_lidar * p.position_m.cast<double>()).z());
    }
    std::vector<double> medians;
    for (std::vector<double>& ring : z) {
      std::nth_element(ring.begin(), ring.begin() + ring.size() / 2, ring.end());
      medians.push_back(ring.empty() ? NAN : ring[ring.size() / 2]);
    }
    return medians;
  };
  const double lidar_height_m = (trajectory.pose(0.5) * rig.T_body_lidar).translation().z();
  const std::vector<double> ideal = ring_heights(SensorRig{});
  const std::vector<double> miscalibrated = ring_heights(rig);
  int ground_rings = 0;
  double largest_offset_m = 0.0;
  for (size_t r = 0; r < spec.elevations_rad.size(); ++r) {
    const double elevation = spec.elevations_rad[r];
    if (elevation > -2.0 * M_PI / 180.0) {
      continue;  // sees the far ground only at grazing angles, or the sky
    }
    ++ground_rings;
    EXPECT_NEAR(ideal[r], 0.0, 0.01) << "ring " << r;
    // The beam fires at elevation + error, meets the ground at that slant range, and the
    // driver places the biased range along the nominal elevation.
    const BeamError& e = errors[r];
    const double true_range_m = lidar_height_m / -std::sin(elevation + e.elevation_rad);
    const double expected_z =
        lidar_height_m + (true_range_m + e.range_bias_m) * std::sin(elevation);
    EXPECT_NEAR(miscalibrated[r], expected_z, 0.01) << "ring " << r;
    largest_offset_m = std::max(largest_offset_m, std::abs(miscalibrated[r]));
  }
  EXPECT_GE(ground_rings, 20);
  EXPECT_GT(largest_offset_m, 0.03) << "the errors must show";
}

TEST(Lidar, ModelsHaveTheirBeamPatterns) {
  EXPECT_EQ(lidar_spec("vlp16").rays_per_sweep(), 16 * 1800);
  EXPECT_EQ(lidar_spec("hdl32").rays_per_sweep(), 32 * 2170);
  EXPECT_EQ(lidar_spec("os1_64").rays_per_sweep(), 64 * 1024);
  const LidarSpec livox = lidar_spec("mid360");
  const std::vector<LidarRay> a = sweep_rays(livox, 0);
  const std::vector<LidarRay> b = sweep_rays(livox, 1);
  ASSERT_EQ(a.size(), 20000u);
  int same = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    same += (a[i].direction - b[i].direction).norm() < 1e-3 ? 1 : 0;
  }
  EXPECT_LT(same, 200) << "the pattern must not repeat from sweep to sweep";
  for (const LidarRay& r : a) {
    EXPECT_NEAR(r.direction.norm(), 1.0f, 1e-5f);
    EXPECT_GE(r.time_offset_s, 0.0f);
    EXPECT_LT(r.time_offset_s, livox.scan_period_s);
    EXPECT_GE(std::asin(r.direction.z()), livox.min_elevation_rad - 1e-4);
    EXPECT_LE(std::asin(r.direction.z()), livox.max_elevation_rad + 1e-4);
  }
  try {
    lidar_spec("hdl64");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("hdl32"), std::string::npos) << e.what();
  }
}

TEST(Sessions, RoutesHaveTheirShapes) {
  const GeneratedWorld& g = campus().generated;
  const SessionPlanConfig lengths;
  const SessionPlan a = plan_session("A", g.world, g.mapped_max_x_m, lengths, 1);
  double length = 0.0;
  for (size_t i = 0; i < a.waypoints.size(); ++i) {
    EXPECT_LT(a.waypoints[i].x(), g.mapped_max_x_m);
    if (i > 0) {
      length += (a.waypoints[i] - a.waypoints[i - 1]).norm();
    }
  }
  EXPECT_TRUE(a.waypoints.front().isApprox(a.waypoints.back())) << "A closes its loop";
  EXPECT_GT(length, lengths.a_length_m);
  EXPECT_LT(length, lengths.a_length_m + 600.0);

  const SessionPlan b = plan_session("B", g.world, g.mapped_max_x_m, lengths, 1);
  EXPECT_LT(b.waypoints.front().x(), g.mapped_max_x_m);
  EXPECT_LT(b.waypoints.back().x(), g.mapped_max_x_m);
  EXPECT_TRUE(std::any_of(b.waypoints.begin(), b.waypoints.end(),
                          [&](const Eigen::Vector2d& w) { return w.x() > g.mapped_max_x_m; }));

  EXPECT_EQ(plan_session("C", g.world, g.mapped_max_x_m, lengths, 1).day, 1);

  const SessionPlan d = plan_session("D", g.world, g.mapped_max_x_m, lengths, 1);
  EXPECT_FALSE(d.initial_pose_known);
  const RoadNetwork& roads = g.world.roads();
  EXPECT_GT((roads.nodes()[roads.nearest_node(d.waypoints.front())] - d.waypoints.front()).norm(),
            10.0)
      << "D starts mid-street";
  EXPECT_THROW(plan_session("E", g.world, g.mapped_max_x_m, lengths, 1), std::invalid_argument);
}

TEST(Sessions, AnotherDayChangesAQuarterOfTheCars) {
  World world = campus().generated.world;
  World again = world;
  const DayChangeConfig config;
  const DayChangeReport r = apply_day_changes(world, 9, config);
  const DayChangeReport r2 = apply_day_changes(again, 9, config);
  EXPECT_EQ(r.cars_moved, r2.cars_moved);
  EXPECT_EQ(world.num_primitives(), again.num_primitives());
  const double changed = static_cast<double>(r.cars_moved + r.cars_removed) / r.cars_total;
  EXPECT_GT(changed, 0.18);
  EXPECT_LT(changed, 0.32);
  EXPECT_EQ(r.structures_added, config.new_structures);
  EXPECT_GT(r.foliage_changed, 100);
}

TEST(Sessions, RunEmitsSamplesAndSweepsInTimeOrder) {
  const World world = flat_world({});
  MotionConfig motion;
  motion.stationary_start_s = 1.0;
  const VehicleTrajectory trajectory(world, {{-40, 0}, {-20, 0}}, motion, 1);
  const SessionSimulator sim(world, trajectory, lidar_spec("vlp16"), SensorRig{}, ImuConfig{}, 5,
                             1000000);
  int64_t last_available = 0;
  int64_t imu = 0, scans = 0;
  bool ordered = true;
  const SessionStats stats = sim.run(
      [&](const ImuSample& s) {
        ordered &= s.utime_us >= last_available;
        last_available = s.utime_us;
        ++imu;
      },
      [&](const LidarScan& s) {
        const int64_t available = s.utime_us + 100000;
        ordered &= available >= last_available;
        last_available = available;
        ++scans;
      },
      [](double) {}, 2);
  EXPECT_TRUE(ordered);
  EXPECT_EQ(stats.sweeps, sim.num_sweeps());
  EXPECT_EQ(scans, stats.sweeps);
  EXPECT_EQ(imu, stats.imu_samples);
  EXPECT_NEAR(static_cast<double>(imu), trajectory.duration_s() * 200.0, 2.0);
  EXPECT_GT(trajectory.duration_s(), 5.0);
}

}  // namespace
}  // namespace liloc::sim
