#include <gtest/gtest.h>

#include <cmath>

#include "math/se3.hpp"
#include "math/so3.hpp"
#include "math/trajectory.hpp"

namespace liloc {
namespace {

constexpr double kPi = M_PI;

TEST(So3, ExpOfQuarterTurnAboutZ) {
  const Eigen::Matrix3d R = so3::exp(Eigen::Vector3d(0, 0, kPi / 2));
  Eigen::Matrix3d expected;
  expected << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  EXPECT_TRUE(R.isApprox(expected, 1e-12)) << R;
}

TEST(So3, HatIsCrossProduct) {
  const Eigen::Vector3d a(1, -2, 3), b(0.5, 4, -1);
  EXPECT_TRUE((so3::hat(a) * b).isApprox(a.cross(b)));
}

TEST(So3, LogInvertsExpAcrossTheRange) {
  for (const double angle : {0.0, 1e-9, 1e-4, 0.5, 2.0, 3.1, kPi - 1e-6}) {
    const Eigen::Vector3d phi = angle * Eigen::Vector3d(1, 2, -0.5).normalized();
    EXPECT_TRUE(so3::log(so3::exp(phi)).isApprox(phi, 1e-9) || phi.norm() < 1e-12)
        << "angle " << angle << " -> " << so3::log(so3::exp(phi)).transpose();
  }
}

TEST(So3, LogAtPiHasNormPi) {
  const Eigen::Matrix3d R = so3::exp(Eigen::Vector3d(kPi, 0, 0));
  EXPECT_NEAR(so3::log(R).norm(), kPi, 1e-9);
  EXPECT_NEAR(std::abs(so3::log(R).x()), kPi, 1e-9);
}

// Jr(phi) relates a perturbation of phi to a right perturbation of Exp(phi).
TEST(So3, RightJacobianMatchesFiniteDifferences) {
  const Eigen::Vector3d phi(0.3, -0.7, 1.1);
  const Eigen::Matrix3d Jr = so3::right_jacobian(phi);
  const double h = 1e-6;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d d = h * Eigen::Vector3d::Unit(k);
    const Eigen::Vector3d numeric = so3::log(so3::exp(phi).transpose() * so3::exp(phi + d)) / h;
    EXPECT_TRUE(numeric.isApprox(Jr.col(k), 1e-5)) << numeric.transpose();
  }
  EXPECT_TRUE((Jr * so3::right_jacobian_inverse(phi)).isIdentity(1e-12));
}

TEST(So3, SmallAngleBranchesAgreeWithClosedForm) {
  const Eigen::Vector3d tiny(1e-8, -2e-8, 3e-8);
  EXPECT_TRUE(so3::right_jacobian(tiny).isApprox(Eigen::Matrix3d::Identity() - 0.5 * so3::hat(tiny),
                                                 1e-14));
  EXPECT_TRUE(so3::exp(tiny).isApprox(Eigen::Matrix3d::Identity() + so3::hat(tiny), 1e-14));
}

TEST(So3, RollPitchYawComposeAsZyx) {
  const Eigen::Matrix3d R = so3::from_rpy(Eigen::Vector3d(0, 0, kPi / 2));
  EXPECT_TRUE((R * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY()));
  const Eigen::Vector3d rpy(0.1, -0.2, 0.3);
  EXPECT_TRUE(so3::from_rpy(rpy).isApprox(so3::exp(Eigen::Vector3d(0, 0, 0.3)) *
                                          so3::exp(Eigen::Vector3d(0, -0.2, 0)) *
                                          so3::exp(Eigen::Vector3d(0.1, 0, 0))));
  EXPECT_TRUE(so3::to_rpy(so3::from_rpy(rpy)).isApprox(rpy, 1e-12));
  EXPECT_TRUE(so3::to_rpy(R).isApprox(Eigen::Vector3d(0, 0, kPi / 2), 1e-12));
}

// Tilt ignores yaw: a pitch of 0.2 rad under any heading tilts by 0.2; upside down is pi.
TEST(So3, TiltIsTheAngleOffUpWhateverTheHeading) {
  EXPECT_NEAR(so3::tilt(so3::from_rpy(Eigen::Vector3d(0, 0.2, 2.5))), 0.2, 1e-12);
  EXPECT_NEAR(so3::tilt(so3::exp(Eigen::Vector3d(0.03, -0.04, 0))), 0.05, 1e-12);
  EXPECT_NEAR(so3::tilt(so3::exp(Eigen::Vector3d(kPi, 0, 0))), kPi, 1e-7);
  EXPECT_EQ(so3::tilt(Eigen::Matrix3d::Identity()), 0.0);
}

TEST(So3, NormalizeRepairsDrift) {
  Eigen::Matrix3d R = so3::exp(Eigen::Vector3d(0.2, 0.1, -0.4));
  R(0, 0) += 1e-4;
  const Eigen::Matrix3d N = so3::normalize(R);
  EXPECT_TRUE((N.transpose() * N).isIdentity(1e-12));
  EXPECT_NEAR(N.determinant(), 1.0, 1e-12);
}

TEST(Se3, ExpOfPureTranslationIsTranslation) {
  Vector6d xi;
  xi << 1, 2, 3, 0, 0, 0;
  const Eigen::Isometry3d T = se3::exp(xi);
  EXPECT_TRUE(T.linear().isIdentity());
  EXPECT_TRUE(T.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
}

// Screw motion: a quarter turn about z while moving 1 m along the arc of radius 2/pi.
TEST(Se3, ExpOfKnownScrewMotion) {
  Vector6d xi;
  xi << 1, 0, 0, 0, 0, kPi / 2;
  const Eigen::Isometry3d T = se3::exp(xi);
  // V = I + (1 - cos)/t^2 W + (t - sin)/t^3 W^2; V * (1, 0, 0) = (sin t / t, (1 - cos t)/t, 0).
  const double t = kPi / 2;
  EXPECT_TRUE(
      T.translation().isApprox(Eigen::Vector3d(std::sin(t) / t, (1 - std::cos(t)) / t, 0), 1e-12))
      << T.translation().transpose();
  EXPECT_NEAR(se3::rotation_angle(T), t, 1e-12);
}

TEST(Se3, LogInvertsExp) {
  Vector6d xi;
  xi << 0.5, -1.0, 2.0, 0.3, -0.2, 1.5;
  EXPECT_TRUE(se3::log(se3::exp(xi)).isApprox(xi, 1e-12));
}

TEST(Se3, CompositionFollowsFrameNames) {
  const Eigen::Isometry3d T_map_odom =
      se3::make(so3::exp(Eigen::Vector3d(0, 0, kPi / 2)), Eigen::Vector3d(10, 0, 0));
  const Eigen::Isometry3d T_odom_body =
      se3::make(Eigen::Matrix3d::Identity(), Eigen::Vector3d(1, 0, 0));
  const Eigen::Isometry3d T_map_body = T_map_odom * T_odom_body;
  EXPECT_TRUE(T_map_body.translation().isApprox(Eigen::Vector3d(10, 1, 0)));
}

TEST(Se3, InterpolateEndsAndMiddle) {
  const Eigen::Isometry3d a = se3::make(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, 0));
  const Eigen::Isometry3d b =
      se3::make(so3::exp(Eigen::Vector3d(0, 0, 1.0)), Eigen::Vector3d(2, 4, 0));
  EXPECT_TRUE(se3::interpolate(a, b, 0.0).isApprox(a));
  EXPECT_TRUE(se3::interpolate(a, b, 1.0).isApprox(b, 1e-12));
  const Eigen::Isometry3d mid = se3::interpolate(a, b, 0.5);
  EXPECT_TRUE(mid.translation().isApprox(Eigen::Vector3d(1, 2, 0)));
  EXPECT_NEAR(se3::rotation_angle(mid), 0.5, 1e-12);
}

TEST(Se3, PlusAndMinusPerturbOnTheRightWithTranslationInTheBodyFrame) {
  const Eigen::Isometry3d T =
      se3::make(so3::exp(Eigen::Vector3d(0, 0, kPi / 2)), Eigen::Vector3d(10, 0, 0));
  Vector6d xi = Vector6d::Zero();
  xi(0) = 1.0;  // one metre along the body's x, which is the parent's y after the turn
  EXPECT_TRUE(se3::plus(T, xi).translation().isApprox(Eigen::Vector3d(10, 1, 0), 1e-12));
  xi << 0.3, -0.2, 0.1, 0.05, -0.02, 0.4;
  EXPECT_TRUE(se3::minus(se3::plus(T, xi), T).isApprox(xi, 1e-12));
  EXPECT_TRUE(se3::plus(T, se3::minus(T * se3::exp(xi), T)).isApprox(T * se3::exp(xi), 1e-12));
}

TEST(Trajectory, InterpolatesBetweenPosesAndRefusesGaps) {
  std::vector<StampedPose> poses;
  poses.push_back({2.0, se3::make(so3::exp(Eigen::Vector3d(0, 0, 1.0)), Eigen::Vector3d(2, 0, 0))});
  poses.push_back({0.0, Eigen::Isometry3d::Identity()});  // out of order on purpose
  poses.push_back({10.0, Eigen::Isometry3d::Identity()});
  const Trajectory trajectory(poses);
  EXPECT_EQ(trajectory.start_time(), 0.0);
  const auto mid = trajectory.at(1.0, 5.0);
  ASSERT_TRUE(mid.has_value());
  EXPECT_TRUE(mid->translation().isApprox(Eigen::Vector3d(1, 0, 0)));
  EXPECT_NEAR(se3::rotation_angle(*mid), 0.5, 1e-12);
  EXPECT_TRUE(trajectory.at(2.0, 0.1).has_value());   // exactly on a pose
  EXPECT_FALSE(trajectory.at(5.0, 1.0).has_value());  // 8 s gap
  EXPECT_FALSE(trajectory.at(-0.1, 5.0).has_value());
  EXPECT_FALSE(trajectory.at(10.1, 5.0).has_value());
  EXPECT_NEAR(trajectory.path_length_m(), 4.0, 1e-12);
}

// A 1 Hz pose file and 2 Hz scans whose times went through microseconds (epoch times,
// where a double keeps about 0.2 us): every scan inside the span gets a pose, the one at
// the span's end included, and a time that does not says why.
TEST(Trajectory, LookupMatchesRoundedTimesAndSaysWhyATimeHasNoPose) {
  const double t0 = 1'700'000'000.123456789;
  std::vector<StampedPose> poses;
  for (int k = 0; k <= 10; ++k) {
    poses.push_back({t0 + k, se3::make(Eigen::Matrix3d::Identity(), Eigen::Vector3d(k, 0, 0))});
  }
  poses.push_back({t0 + 14.0, Eigen::Isometry3d::Identity()});  // a 4 s gap
  const Trajectory trajectory(poses);
  for (int k = 0; k <= 20; ++k) {
    const double scan_time = std::round((t0 + 0.5 * k) * 1e6) * 1e-6;  // as a utime
    const TrajectoryLookup at = trajectory.lookup(scan_time, 1.5, 1e-3);
    ASSERT_TRUE(at.T.has_value()) << "scan " << k;
    EXPECT_NEAR(at.T->translation().x(), 0.5 * k, 1e-3) << "scan " << k;
  }
  EXPECT_FALSE(trajectory.at(std::round((t0 + 10.0) * 1e6) * 1e-6 + 1e-7, 1.5));  // no tolerance
  const TrajectoryLookup gap = trajectory.lookup(t0 + 12.0, 1.5, 1e-3);
  EXPECT_FALSE(gap.T.has_value());
  EXPECT_EQ(gap.coverage, TrajectoryCoverage::kInGap);
  EXPECT_NEAR(gap.gap_s, 4.0, 1e-6);
  EXPECT_EQ(trajectory.lookup(t0 - 0.01, 1.5, 1e-3).coverage, TrajectoryCoverage::kBeforeStart);
  EXPECT_EQ(trajectory.lookup(t0 + 14.01, 1.5, 1e-3).coverage, TrajectoryCoverage::kAfterEnd);
}

TEST(Trajectory, RejectsDuplicateTimestamps) {
  EXPECT_THROW(
      Trajectory({{1.0, Eigen::Isometry3d::Identity()}, {1.0, Eigen::Isometry3d::Identity()}}),
      std::invalid_argument);
}

}  // namespace
}  // namespace liloc
