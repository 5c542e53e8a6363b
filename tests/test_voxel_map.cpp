#include <gtest/gtest.h>

#include <random>

#include "voxel_map/voxel_hash_map.hpp"

namespace liloc {
namespace {

TEST(VoxelHashMap, NearestMatchesBruteForceWithinHalfAVoxel) {
  VoxelMapConfig config;
  config.voxel_m = 1.0;
  config.min_point_spacing_m = 0.0;
  VoxelHashMap map(config);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-5.0f, 5.0f);
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 2000; ++i) {
    points.emplace_back(u(rng), u(rng), 0.2f * u(rng));
  }
  map.insert(points);
  ASSERT_EQ(map.num_points(), map.points().size());
  const std::vector<Eigen::Vector3f> stored = map.points();
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector3f q(u(rng), u(rng), 0.0f);
    // Exact within half a voxel.
    const Neighbors<5> n = map.nearest<5>(q, 0.5f);
    std::vector<float> brute;
    for (const Eigen::Vector3f& p : stored) {
      const float d = (p - q).squaredNorm();
      if (d <= 0.25f) {
        brute.push_back(d);
      }
    }
    std::sort(brute.begin(), brute.end());
    ASSERT_EQ(n.count, static_cast<int>(std::min<size_t>(5, brute.size())));
    for (int k = 0; k < n.count; ++k) {
      EXPECT_FLOAT_EQ(n.squared_distances[k], brute[k]);
      EXPECT_FLOAT_EQ((n.points[k] - q).squaredNorm(), brute[k]);
    }
  }
}

TEST(VoxelHashMap, CapsPointsPerVoxelAndKeepsSpacing) {
  VoxelMapConfig config;
  config.voxel_m = 1.0;
  config.max_points_per_voxel = 5;
  config.min_point_spacing_m = 0.1;
  VoxelHashMap map(config);
  map.insert({{0.5f, 0.5f, 0.5f}, {0.52f, 0.5f, 0.5f}});  // the second is too close
  EXPECT_EQ(map.num_points(), 1u);
  std::vector<Eigen::Vector3f> many;
  for (int i = 0; i < 9; ++i) {
    many.emplace_back(0.1f * i + 0.05f, 0.2f, 0.2f);
  }
  map.insert(many);
  EXPECT_EQ(map.num_points(), 5u);
  EXPECT_EQ(map.num_voxels(), 1u);
}

TEST(VoxelHashMap, KeepsTheDirectionEachPointWasSeenFrom) {
  VoxelMapConfig config;
  config.voxel_m = 1.0;
  config.min_point_spacing_m = 0.3;
  VoxelHashMap map(config);
  const Eigen::Vector3f near_face(0.2f, 0.2f, 0.2f);
  const Eigen::Vector3f far_face(0.6f, 0.2f, 0.2f);
  map.insert({near_face}, Eigen::Vector3f(-5.0f, 0.2f, 0.2f));
  map.insert({far_face}, Eigen::Vector3f(5.6f, 0.2f, 5.2f));
  map.insert({Eigen::Vector3f(0.25f, 0.2f, 0.2f)});  // crowded out: spacing, not view
  EXPECT_EQ(map.num_points(), 2u);
  const Neighbors<2> n = map.nearest<2>(near_face, 0.5f);
  ASSERT_EQ(n.count, 2);
  EXPECT_EQ(n.views[0], ViewDirection(-127, 0, 0));
  EXPECT_EQ(n.views[1], ViewDirection(90, 0, 90));  // 45 degrees up, rounded

  // Moved into another frame, the views turn with the points; points of unknown view stay so.
  map.insert({Eigen::Vector3f(0.2f, 0.9f, 0.2f)});
  VoxelHashMap turned(config);
  Eigen::Isometry3f T_turned_map = Eigen::Isometry3f::Identity();
  T_turned_map.rotate(
      Eigen::AngleAxisf(0.5f * static_cast<float>(EIGEN_PI), Eigen::Vector3f::UnitZ()));
  T_turned_map.pretranslate(Eigen::Vector3f(10.0f, 0.0f, 0.0f));
  turned.insert(map, T_turned_map);
  ASSERT_EQ(turned.num_points(), 3u);
  EXPECT_EQ(turned.nearest<1>(T_turned_map * near_face, 0.05f).views[0], ViewDirection(0, -127, 0));
  EXPECT_EQ(turned.nearest<1>(T_turned_map * Eigen::Vector3f(0.2f, 0.9f, 0.2f), 0.05f).views[0],
            ViewDirection::Zero());
}

TEST(VoxelHashMap, RemoveFarBoundsTheMap) {
  VoxelMapConfig config;
  config.voxel_m = 1.0;
  config.keep_radius_m = 10.0;
  VoxelHashMap map(config);
  std::vector<Eigen::Vector3f> line;
  for (int x = -50; x <= 50; ++x) {
    line.emplace_back(x + 0.5f, 0.5f, 0.5f);
  }
  map.insert(line);
  EXPECT_EQ(map.num_voxels(), 101u);
  map.remove_far(Eigen::Vector3d(20.0, 0.0, 0.0));
  EXPECT_EQ(map.num_voxels(), 20u);  // x + 0.5 within 10 m of 20: x = 10 .. 29
  EXPECT_EQ(map.num_points(), 20u);
}

TEST(VoxelHashMap, ConfigIsValidated) {
  VoxelMapConfig config;
  config.max_points_per_voxel = 100;
  EXPECT_THROW(VoxelHashMap{config}, std::invalid_argument);
}

}  // namespace
}  // namespace liloc
