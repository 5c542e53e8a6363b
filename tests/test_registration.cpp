#include <gtest/gtest.h>

#include <limits>
#include <random>
#include <stdexcept>

#include "math/so3.hpp"
#include "pointcloud/voxel_grid.hpp"
#include "real_pair.hpp"
#include "registration/correlative_search.hpp"
#include "registration/point_to_plane_registration.hpp"

namespace liloc {
namespace {

constexpr double kPi = 3.141592653589793;

// Points on the three walls of a room corner and a floor: every direction constrained.
std::vector<Eigen::Vector3f> room(std::mt19937& rng, float noise) {
  std::uniform_real_distribution<float> u(0.0f, 10.0f);
  std::normal_distribution<float> n(0.0f, noise);
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 3000; ++i) {
    pts.emplace_back(u(rng), u(rng), n(rng));                 // floor
    pts.emplace_back(n(rng), u(rng), 0.3f * u(rng));          // wall x = 0
    pts.emplace_back(u(rng), n(rng), 0.3f * u(rng));          // wall y = 0
    pts.emplace_back(u(rng), 10.0f + n(rng), 0.3f * u(rng));  // wall y = 10
  }
  return pts;
}

VoxelHashMap map_of(const std::vector<Eigen::Vector3f>& pts, double voxel = 0.5) {
  VoxelMapConfig config;
  config.voxel_m = voxel;
  config.min_point_spacing_m = 0.05;
  VoxelHashMap map(config);
  map.insert(pts);
  return map;
}

std::vector<Eigen::Vector3f> transformed(const std::vector<Eigen::Vector3f>& pts,
                                         const Eigen::Isometry3d& T) {
  std::vector<Eigen::Vector3f> out;
  for (const auto& p : pts) {
    out.push_back((T * p.cast<double>()).cast<float>());
  }
  return out;
}

TEST(FitPlane, RecoversAPlaneAndRejectsClutter) {
  const Eigen::Vector3f flat[5] = {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {1, 1, 1}, {0.5f, 0.5f, 1}};
  const auto plane = fit_plane(flat, 5, 0.1, 0.4);
  ASSERT_TRUE(plane);
  EXPECT_NEAR(std::abs(plane->normal.z()), 1.0, 1e-9);
  EXPECT_NEAR(plane->normal.dot(Eigen::Vector3d(3, 4, 1)) + plane->offset, 0.0, 1e-9);
  const Eigen::Vector3f bumpy[5] = {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {1, 1, 1}, {0.5f, 0.5f, 1.5f}};
  EXPECT_FALSE(fit_plane(bumpy, 5, 0.1, 0.4));
  const Eigen::Vector3f line[5] = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}, {4, 0, 0}};
  EXPECT_FALSE(fit_plane(line, 5, 0.1, 0.4));
  // A band 4 m long and 2.2 m wide: second over largest eigenvalue is 1.1^2 / 4 = 0.3025.
  const Eigen::Vector3f band[5] = {
      {-2, 1.1f, 0}, {2, 1.1f, 0}, {-2, -1.1f, 0}, {2, -1.1f, 0}, {0, 0, 0}};
  EXPECT_TRUE(fit_plane(band, 5, 0.1, 0.25));
  EXPECT_FALSE(fit_plane(band, 5, 0.1, 0.4));
}

TEST(Registration, RecoversAKnownPoseInARoom) {
  std::mt19937 rng(1);
  const auto target = room(rng, 0.01f);
  const VoxelHashMap map = map_of(target);
  const Eigen::Isometry3d T_true =
      se3::make(so3::exp(Eigen::Vector3d(0.02, -0.01, 0.1)), Eigen::Vector3d(0.4, -0.3, 0.1));
  // The source sees the room from the true pose: source = T_true^-1 * target.
  const auto source = transformed(room(rng, 0.01f), T_true.inverse());
  // Seen from 1.5 m above the middle of the floor.
  const RegistrationResult r =
      register_point_to_plane(source, map, Eigen::Isometry3d::Identity(), std::nullopt,
                              RegistrationConfig{}, Eigen::Vector3d(5.0, 5.0, 1.5));
  EXPECT_TRUE(r.converged);
  EXPECT_LT((r.T_target_source.translation() - T_true.translation()).norm(), 0.01);
  EXPECT_LT(so3::log(T_true.linear().transpose() * r.T_target_source.linear()).norm(), 1e-3);
  EXPECT_LT(r.rms_residual_m, 0.03);
  EXPECT_FALSE(r.degenerate);
}

// In a corridor (floor and two parallel walls) translation along it is unobservable:
// the registration reports degeneracy, and a prior holds the pose where the scan cannot.
TEST(Registration, CorridorIsDegenerateAndThePriorHoldsIt) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> u(0.0f, 30.0f);
  std::normal_distribution<float> n(0.0f, 0.01f);
  std::vector<Eigen::Vector3f> corridor;
  for (int i = 0; i < 6000; ++i) {
    corridor.emplace_back(u(rng), 0.1f * u(rng), n(rng));
    corridor.emplace_back(u(rng), n(rng), 0.1f * u(rng));
    corridor.emplace_back(u(rng), 3.0f + n(rng), 0.1f * u(rng));
  }
  const VoxelHashMap map = map_of(corridor);
  // The middle of the corridor only: its ends would tell where along it we are.
  std::vector<Eigen::Vector3f> source;
  for (const Eigen::Vector3f& p : corridor) {
    if (p.x() > 5.0f && p.x() < 25.0f && source.size() < 6000) {
      source.push_back(p);
    }
  }
  PosePrior prior;
  prior.T_target_source = se3::make(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.7, 0, 0));
  prior.information = Matrix6d::Identity() * 100.0;  // 10 cm, 0.1 rad
  const RegistrationResult r =
      register_point_to_plane(source, map, prior.T_target_source, prior, RegistrationConfig{});
  EXPECT_TRUE(r.degenerate);
  EXPECT_LT(r.translation_eigen_ratio, 0.02);
  EXPECT_NEAR(r.T_target_source.translation().x(), 0.7, 0.05) << "along the corridor: the prior";
  EXPECT_NEAR(r.T_target_source.translation().y(), 0.0, 0.01) << "across it: the walls";
  // What it determined: in translation, the two directions across the corridor.
  const Matrix6d constrained = constrained_directions(r.information, 0.02);
  EXPECT_NEAR(constrained.block(0, 0, 3, 3).trace(), 2.0, 1e-9);
  EXPECT_LT((constrained * Vector6d::Unit(0)).norm(), 0.1);
  EXPECT_NEAR((constrained * Vector6d::Unit(1)).norm(), 1.0, 0.01);
  // As if from 200 independent matches: the information scaled down by matches / 200.
  EXPECT_TRUE(r.independent_information(200).isApprox(r.information * 200.0 /
                                                      static_cast<double>(r.correspondences)));
}

// A room 10 m square with a divider at x = divider_x (from y = 1 to 3.5), points 5 mm noisy.
std::vector<Eigen::Vector3f> divided_room(std::mt19937& rng, float divider_x) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> n(0.0f, 0.005f);
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 1500; ++i) {
    pts.emplace_back(10.0f * u(rng), 10.0f * u(rng), n(rng));                   // floor
    pts.emplace_back(10.0f * u(rng), n(rng), 3.0f * u(rng));                    // wall y = 0
    pts.emplace_back(10.0f * u(rng), 10.0f + n(rng), 3.0f * u(rng));            // wall y = 10
    pts.emplace_back(divider_x + n(rng), 1.0f + 2.5f * u(rng), 3.0f * u(rng));  // divider
  }
  for (int i = 0; i < 300; ++i) {
    pts.emplace_back(10.0f + n(rng), 10.0f * u(rng), 3.0f * u(rng));  // far wall x = 10
  }
  return pts;
}

// The map of divided_room seen from x = 1, which saw the divider's face at x = 4 from one
// side, and sweeps of it from x = 7, which see the divider's other side.
struct DividerSeenFromBothSides {
  std::mt19937 rng{5};
  VoxelHashMap map{[] {
    VoxelMapConfig c;
    c.voxel_m = 0.5;
    c.min_point_spacing_m = 0.05;
    return c;
  }()};
  const Eigen::Isometry3d T_map_sensor{Eigen::Translation3d(7.0, 5.0, 1.5)};

  DividerSeenFromBothSides() {
    map.insert(divided_room(rng, 4.0f), Eigen::Vector3f(1.0f, 5.0f, 1.5f));
  }
  // A sweep from x = 7 whose divider lies at divider_x, in the sensor's frame.
  std::vector<Eigen::Vector3f> sweep(float divider_x) {
    return transformed(divided_room(rng, divider_x), T_map_sensor.inverse());
  }
  // Registered from the true pose.
  RegistrationResult register_sweep(const std::vector<Eigen::Vector3f>& points,
                                    const RegistrationConfig& config) const {
    return register_point_to_plane(points, map, T_map_sensor, std::nullopt, config);
  }
};

// The divider is 0.3 m thick: the sweep, from x = 7, sees its other face at x = 4.3. Within
// the association radius that face matches the first's plane and pulls the sweep back,
// unless the map's view directions show it seen from the other side.
TEST(Registration, AThinWallsOtherFaceDoesNotPullTheSweep) {
  DividerSeenFromBothSides room;
  const auto sweep = room.sweep(4.3f);
  RegistrationConfig config;
  config.reject_back_faces = false;
  const RegistrationResult pulled = room.register_sweep(sweep, config);
  EXPECT_LT(pulled.T_target_source.translation().x() - 7.0, -0.02);
  config.reject_back_faces = true;
  const RegistrationResult kept = room.register_sweep(sweep, config);
  EXPECT_TRUE(kept.converged);
  EXPECT_LT((kept.T_target_source.translation() - room.T_map_sensor.translation()).norm(), 0.005);
}

// A divider with no thickness (a fence, or a side misjudged where the sensor crossed a
// plane's extension): the sweep from x = 7 sees the very plane the map saw from x = 1. Its
// points lie on that plane, nearer than back_face_min_offset_m, so the views alone do not
// refuse them; with the bound at 0 they do: 1383 matches instead of 1517, the divider's all
// refused (only 131 of its points find a plane at all in this map).
TEST(Registration, APointOnThePlaneIsMatchedWhateverItsViews) {
  DividerSeenFromBothSides room;
  const auto sweep = room.sweep(4.0f);
  RegistrationConfig config;
  const RegistrationResult matched = room.register_sweep(sweep, config);
  config.back_face_min_offset_m = 0.0;
  const RegistrationResult refused = room.register_sweep(sweep, config);
  EXPECT_TRUE(matched.converged);
  EXPECT_LT((matched.T_target_source.translation() - room.T_map_sensor.translation()).norm(),
            0.005);
  EXPECT_GT(matched.correspondences, refused.correspondences + 100);
}

// A street seen from a sensor 1.5 m above its ground: the ground and two facades within
// 10 m, and far ahead, 30 m off and 4 m above the sensor, the underside of a canopy.
// `canopy_drop_m` lowers the canopy, as a map that took it in at a tilted pose holds it.
std::vector<Eigen::Vector3f> street_with_a_far_canopy(std::mt19937& rng, float canopy_drop_m) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::normal_distribution<float> n(0.0f, 0.005f);
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 3000; ++i) {
    pts.emplace_back(10.0f * u(rng), 8.0f * u(rng), -1.5f + n(rng));              // ground
    pts.emplace_back(10.0f * u(rng), 8.0f + n(rng), 2.0f + 3.5f * u(rng));        // facade
    pts.emplace_back(10.0f * u(rng), -8.0f + n(rng), 2.0f + 3.5f * u(rng));       // facade
    pts.emplace_back(7.0f + n(rng), 6.0f + 2.0f * u(rng), 2.0f + 3.5f * u(rng));  // a step
  }
  for (int i = 0; i < 3000; ++i) {
    pts.emplace_back(30.0f + 5.0f * u(rng), 5.0f * u(rng), 4.0f - canopy_drop_m + n(rng));
  }
  return pts;
}

// A far ceiling matched tilts the sweep toward wherever the map holds it (a ring LiDAR's
// map holds it off by its sweeps' tilt: docs/odometry.md): here 0.52 degrees, and x 2 cm
// short. Left out (RegistrationConfig::far_ceiling_beyond_m), the ground holds the tilt
// and the height, and the facades the heading and the position along the ground.
TEST(Registration, AFarCeilingNeedNotTiltTheSweep) {
  std::mt19937 rng(6);
  const VoxelHashMap map = map_of(street_with_a_far_canopy(rng, 0.3f));
  const Eigen::Isometry3d T_true =
      se3::make(so3::exp(Eigen::Vector3d(0, 0, 0.03)), Eigen::Vector3d(0.2, -0.1, 0.0));
  const auto sweep = transformed(street_with_a_far_canopy(rng, 0.0f), T_true.inverse());
  const auto registered = [&](double far_ceiling_beyond_m) {
    RegistrationConfig config;
    config.far_ceiling_beyond_m = far_ceiling_beyond_m;
    return register_point_to_plane(sweep, map, Eigen::Isometry3d::Identity(), std::nullopt, config);
  };
  const auto error_deg = [&](const RegistrationResult& r) -> Eigen::Vector3d {
    return so3::log(T_true.linear().transpose() * r.T_target_source.linear()) * so3::kRadToDeg;
  };
  const RegistrationResult matched = registered(0.0);
  const RegistrationResult left_out = registered(20.0);
  ASSERT_TRUE(matched.converged);
  ASSERT_TRUE(left_out.converged);
  EXPECT_GT(error_deg(matched).head<2>().norm(), 0.3);  // 0.52
  EXPECT_LT(error_deg(left_out).norm(), 0.02);
  EXPECT_LT((left_out.T_target_source.translation() - T_true.translation()).norm(), 0.005);
  EXPECT_LT(left_out.correspondences, matched.correspondences);
}

// The information and the steps are over the right perturbation (math/se3.hpp): from the
// solution moved to T Exp(xi), one Gauss-Newton step comes back by -xi along every axis.
// The body is yawed 90 degrees and x and y are constrained unequally, so Jacobians in any
// other convention (translation in the map frame, say) would step the wrong way.
TEST(Registration, StepsAndInformationAreOverTheRightPerturbation) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(0.0f, 10.0f);
  std::normal_distribution<float> n(0.0f, 0.002f);
  std::vector<Eigen::Vector3f> target;  // a floor, a wall x = 0 and a short wall y = 0
  for (int i = 0; i < 4000; ++i) {
    target.emplace_back(u(rng), u(rng), n(rng));
    target.emplace_back(n(rng), u(rng), 0.3f * u(rng));
    if (i % 8 == 0) {
      target.emplace_back(u(rng), n(rng), 0.3f * u(rng));
    }
  }
  const VoxelHashMap map = map_of(target);
  const Eigen::Isometry3d T_true =
      se3::make(so3::exp(Eigen::Vector3d(0, 0, M_PI / 2)), Eigen::Vector3d(5, 5, 1));
  const auto source = transformed(target, T_true.inverse());
  RegistrationConfig config;
  config.cauchy_scale_m = 1e3;  // quadratic: one Gauss-Newton step is exact
  const RegistrationResult r = register_point_to_plane(source, map, T_true, std::nullopt, config);
  ASSERT_TRUE(r.converged);
  ASSERT_GT(r.correspondences, 1000);
  config.max_iterations = 1;
  for (int axis = 0; axis < 6; ++axis) {
    Vector6d xi = Vector6d::Zero();
    xi(axis) = axis < 3 ? 0.02 : 0.002;
    const Eigen::Isometry3d start = se3::plus(r.T_target_source, xi);
    const RegistrationResult step =
        register_point_to_plane(source, map, start, std::nullopt, config);
    const Vector6d error = se3::minus(step.T_target_source, start) + xi;  // back by -xi?
    EXPECT_LT(error.head<3>().norm(), 1e-3) << "axis " << axis << ": " << error.transpose();
    EXPECT_LT(error.tail<3>().norm(), 1e-4) << "axis " << axis << ": " << error.transpose();
  }
}

// A spinning LiDAR's sweep deskewed with the wrong twist (3 m/s too fast forward, 0.5 m/s
// sideways, 0.2 rad/s in yaw: a vehicle that braked and turned in a pause): each point is off
// by its time before the sweep's end times the error, 0.3 m at the sweep's start. The pose
// alone absorbs part of that and lands off; registered with a correction to the twist, the
// correction undoes the error and the pose is the truth. Times and points must pair.
TEST(Registration, ATwistCorrectionUndoesADeskewAtTheWrongTwist) {
  std::mt19937 rng(6);
  const VoxelHashMap map = map_of(room(rng, 0.005f));
  const Eigen::Isometry3d T_true =
      se3::make(so3::exp(Eigen::Vector3d(0.0, 0.0, 0.3)), Eigen::Vector3d(5.0, 5.0, 1.5));
  Vector6d twist_error;  // deskewed with minus driven: [v (m/s); omega (rad/s)]
  twist_error << 3.0, -0.5, 0.0, 0.0, 0.0, -0.2;
  std::vector<Eigen::Vector3f> source;
  std::vector<double> tau_s;
  for (const Eigen::Vector3f& w : room(rng, 0.005f)) {
    const Eigen::Vector3d p = T_true.inverse() * w.cast<double>();
    const double tau = -0.1 * (std::atan2(p.y(), p.x()) + kPi) / (2.0 * kPi);  // by azimuth
    source.push_back(
        (p + tau * (twist_error.head<3>() + twist_error.tail<3>().cross(p))).cast<float>());
    tau_s.push_back(tau);
  }
  const RegistrationConfig config;
  const RegistrationResult alone =
      register_point_to_plane(source, map, T_true, std::nullopt, config);
  Matrix6d twist_information = Matrix6d::Zero();  // the odometry's: 2 m/s, 0.5 rad/s
  twist_information.diagonal() << 0.25, 0.25, 0.25, 4.0, 4.0, 4.0;
  const TwistRegistrationResult joint = register_point_to_plane_with_twist(
      source, tau_s, map, T_true, std::nullopt, twist_information, config);
  EXPECT_TRUE(joint.pose.converged);
  // Measured: -3.00, 0.62, -0.01 m/s and 0.001, 0.007, 0.204 rad/s; the pose 3 mm off, alone
  // 0.24 m.
  const Vector6d left = joint.twist_correction + twist_error;
  EXPECT_LT(left.head<3>().norm(), 0.2) << joint.twist_correction.transpose();
  EXPECT_LT(left.tail<3>().norm(), 0.02) << joint.twist_correction.transpose();
  EXPECT_LT((joint.pose.T_target_source.translation() - T_true.translation()).norm(), 0.01);
  EXPECT_GT((alone.T_target_source.translation() - T_true.translation()).norm(), 0.1);
  EXPECT_GT(joint.twist_information.diagonal().minCoeff(), 0.0);
  tau_s.pop_back();
  EXPECT_THROW(register_point_to_plane_with_twist(source, tau_s, map, T_true, std::nullopt,
                                                  twist_information, config),
               std::invalid_argument);
}

// Levenberg-Marquardt that cannot lower the cost has not converged: here a non-finite
// start makes every step's cost NaN.
TEST(Registration, AStallIsNotConvergence) {
  std::mt19937 rng(5);
  const VoxelHashMap map = map_of(room(rng, 0.01f));
  PosePrior prior;
  prior.information = Matrix6d::Identity();
  Eigen::Isometry3d guess = Eigen::Isometry3d::Identity();
  guess.translation().x() = std::numeric_limits<double>::quiet_NaN();
  const RegistrationResult r =
      register_point_to_plane(room(rng, 0.01f), map, guess, prior, RegistrationConfig{});
  EXPECT_FALSE(r.converged);
}

TEST(Registration, EmptyMapLeavesTheGuess) {
  const VoxelHashMap map = map_of({});
  const Eigen::Isometry3d guess = se3::make(Eigen::Matrix3d::Identity(), Eigen::Vector3d(1, 2, 3));
  const RegistrationResult r =
      register_point_to_plane({{1, 1, 1}}, map, guess, std::nullopt, RegistrationConfig{});
  EXPECT_TRUE(r.T_target_source.isApprox(guess));
  EXPECT_EQ(r.correspondences, 0);
}

std::vector<Eigen::Vector3f> read_cloud(const std::string& path, float voxel) {
  return test::RealPair::read(path, voxel).points;
}

// Real Velodyne scans (fast_gicp's sample pair): relative.txt takes the source onto the
// target. Registration from the identity must recover it within 5 cm / 0.5 deg.
TEST(Registration, RecoversTheRealPairWithinFiveCentimetresAndHalfADegree) {
  const test::RealPair pair;
  const Eigen::Isometry3d T_target_source = pair.T_target_source();
  const VoxelHashMap map = map_of(read_cloud(pair.target_pcd, 0.1f), 0.5);
  const std::vector<Eigen::Vector3f> source = read_cloud(pair.source_pcd, 0.3f);
  const RegistrationResult r = register_point_to_plane(source, map, Eigen::Isometry3d::Identity(),
                                                       std::nullopt, RegistrationConfig{});
  const Eigen::Isometry3d error = T_target_source.inverse() * r.T_target_source;
  EXPECT_LT(error.translation().norm(), 0.05) << error.translation().transpose();
  EXPECT_LT(se3::rotation_angle(error) * 180.0 / M_PI, 0.5);
  // Sanity: the pose rests on many planes, not a lucky few. Only part of this real scan
  // forms planar patches at the map's density: 761 of its 4950 points match.
  EXPECT_GT(r.correspondences, static_cast<int>(source.size()) / 10);
}

// The correlative search finds a pose 3.4 m, 2.2 m and 20 degrees from its window's centre
// to within its grid (1 m, 2 degrees), best first, its peaks distinct.
TEST(CorrelativeSearch, FindsThePoseInItsWindow) {
  std::mt19937 rng(6);
  const std::vector<Eigen::Vector3f> place = room(rng, 0.01f);
  const Eigen::Isometry3d truth =
      se3::make(so3::exp(Eigen::Vector3d(0, 0, 20.0 * kPi / 180.0)), Eigen::Vector3d(3.4, -2.2, 0));
  const CorrelativeSearchConfig config;
  const CorrelativeSearch search(place, config);
  SearchWindow window;
  window.half_xy_m = 6.0;
  window.half_yaw_rad = 0.63;
  const std::vector<ScoredPose> peaks =
      search.search(transformed(place, truth.inverse()), Eigen::Matrix3d::Identity(), window);
  ASSERT_EQ(peaks.size(), static_cast<size_t>(config.peaks));
  const Eigen::Isometry3d error = truth.inverse() * peaks.front().T_map_body;
  EXPECT_LT(error.translation().head<2>().norm(), 0.75) << error.translation().transpose();
  EXPECT_LE(se3::rotation_angle(error) * 180.0 / kPi, config.yaw_step_deg + 1e-6);
  for (size_t i = 1; i < peaks.size(); ++i) {
    EXPECT_LE(peaks[i].score, peaks[i - 1].score);
    const Eigen::Isometry3d d = peaks.front().T_map_body.inverse() * peaks[i].T_map_body;
    EXPECT_TRUE(d.translation().norm() >= config.distinct_m ||
                se3::rotation_angle(d) * 180.0 / kPi >= config.distinct_deg - 1e-6);
  }
}

TEST(RegistrationStages, NeedOneValueOfEachPerStage) {
  RegistrationStages stages{{1.0, 0.5}, {1.5, 0.6}, {0.15, 0.06}};
  EXPECT_NO_THROW(stages.validate());
  const RegistrationConfig fine = stages.stage(1, RegistrationConfig{});
  EXPECT_DOUBLE_EQ(fine.max_correspondence_m, 0.6);
  EXPECT_DOUBLE_EQ(fine.max_plane_thickness_m, 0.06);
  stages.plane_thickness_m.pop_back();
  EXPECT_THROW(stages.validate(), std::invalid_argument);
  EXPECT_THROW((RegistrationStages{{}, {}, {}}).validate(), std::invalid_argument);
  EXPECT_THROW((RegistrationStages{{1.0}, {-1.0}, {0.1}}).validate(), std::invalid_argument);
}

}  // namespace
}  // namespace liloc
