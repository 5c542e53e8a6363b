#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

#include "dataset/tum_trajectory.hpp"
#include "math/se3.hpp"
#include "math/so3.hpp"

namespace liloc {
namespace {

std::string temp_file(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}

std::string error_of(const std::string& text) {
  const std::string path = temp_file("liloc_bad.tum", text);
  try {
    read_tum(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(TumTrajectory, WriteThenReadIsExact) {
  std::vector<StampedPose> poses;
  for (int i = 0; i < 20; ++i) {
    poses.push_back(
        {1700000000.0 + 0.1 * i, se3::make(so3::exp(Eigen::Vector3d(0.01 * i, -0.02 * i, 0.3 * i)),
                                           Eigen::Vector3d(i, -2.0 * i, 0.5))});
  }
  const std::string path = ::testing::TempDir() + "liloc_roundtrip.tum";
  write_tum(path, Trajectory(poses));
  const Trajectory back = read_tum(path);
  ASSERT_EQ(back.size(), poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_NEAR(back.poses()[i].time_s, poses[i].time_s, 1e-6);
    EXPECT_TRUE(back.poses()[i].T.isApprox(poses[i].T, 1e-8));
  }
  std::remove(path.c_str());
}

TEST(TumTrajectory, SkipsCommentsAndBlankLines) {
  const std::string path = temp_file(
      "liloc_comments.tum", "# header\n\n1.0 0 0 0 0 0 0 1\n  # indented\n2.0 1 0 0 0 0 0 1\n");
  EXPECT_EQ(read_tum(path).size(), 2u);
}

TEST(TumTrajectory, ErrorsNameFileAndLine) {
  std::string e = error_of("1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 1\n");
  EXPECT_NE(e.find("liloc_bad.tum:2"), std::string::npos) << e;
  EXPECT_NE(e.find("expected 8 numbers"), std::string::npos) << e;
  e = error_of("1.0 0 0 nan 0 0 0 1\n");
  EXPECT_NE(e.find(":1: non-finite"), std::string::npos) << e;
  e = error_of("1.0 0 0 0 0 0 0 2\n");
  EXPECT_NE(e.find("quaternion norm"), std::string::npos) << e;
  e = error_of("1.0 0 0 0 0 0 0 1 9\n");
  EXPECT_NE(e.find("more than 8 fields"), std::string::npos) << e;
  e = error_of("1.0 0 0 0 0 0 0 1\n1.0 0 0 0 0 0 0 1\n");
  EXPECT_NE(e.find("two poses at time"), std::string::npos) << e;
  EXPECT_THROW(read_tum("/nonexistent.tum"), std::runtime_error);
}

}  // namespace
}  // namespace liloc
