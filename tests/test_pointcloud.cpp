#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "pointcloud/compact_cloud.hpp"
#include "pointcloud/elevation_gap.hpp"
#include "pointcloud/voxel_grid.hpp"
#include "pointcloud/voxel_index_table.hpp"

namespace liloc {
namespace {

TEST(VoxelGrid, IndexFloorsNegativeCoordinates) {
  EXPECT_EQ(voxel_index(Eigen::Vector3f(-0.1f, 0.1f, 1.05f), 0.5f), Eigen::Vector3i(-1, 0, 2));
}

TEST(VoxelGrid, KeysOfNeighbouringVoxelsDiffer) {
  const uint64_t k = voxel_key(Eigen::Vector3i(0, 0, 0));
  EXPECT_NE(k, voxel_key(Eigen::Vector3i(1, 0, 0)));
  EXPECT_NE(k, voxel_key(Eigen::Vector3i(0, -1, 0)));
  EXPECT_NE(k, voxel_key(Eigen::Vector3i(0, 0, 1)));
  EXPECT_NE(voxel_key(Eigen::Vector3i(-1, 0, 0)), voxel_key(Eigen::Vector3i(0, 0, -1)));
}

TEST(VoxelGrid, DownsampleKeepsOneCentroidPerVoxel) {
  PointCloud cloud;
  cloud.push_back(Eigen::Vector3f(0.1f, 0.1f, 0.1f), 1.0f);
  cloud.push_back(Eigen::Vector3f(0.3f, 0.3f, 0.3f), 3.0f);   // same 1 m voxel
  cloud.push_back(Eigen::Vector3f(5.5f, 0.5f, 0.5f), 7.0f);   // another voxel
  cloud.push_back(Eigen::Vector3f(-0.5f, 0.5f, 0.5f), 9.0f);  // negative side
  const PointCloud out = voxel_downsample(cloud, 1.0f);
  ASSERT_EQ(out.size(), 3u);
  // Order of first appearance.
  EXPECT_TRUE(out.points[0].isApprox(Eigen::Vector3f(0.2f, 0.2f, 0.2f)));
  EXPECT_FLOAT_EQ(out.intensities[0], 2.0f);
  EXPECT_TRUE(out.points[1].isApprox(Eigen::Vector3f(5.5f, 0.5f, 0.5f)));
  EXPECT_TRUE(out.points[2].isApprox(Eigen::Vector3f(-0.5f, 0.5f, 0.5f)));
}

TEST(VoxelGrid, NonPositiveVoxelReturnsInput) {
  PointCloud cloud;
  cloud.push_back(Eigen::Vector3f(0, 0, 0), 1.0f);
  cloud.push_back(Eigen::Vector3f(0, 0, 0), 2.0f);
  EXPECT_EQ(voxel_downsample(cloud, 0.0f).size(), 2u);
}

TEST(VoxelGrid, DenseGridReducesToVoxelCount) {
  PointCloud cloud;
  for (int x = 0; x < 40; ++x) {
    for (int y = 0; y < 40; ++y) {
      cloud.push_back(Eigen::Vector3f(0.05f * x + 0.01f, 0.05f * y + 0.01f, 0.0f), 0.0f);
    }
  }
  // 2 m x 2 m at 0.5 m voxels: 16 voxels.
  EXPECT_EQ(voxel_downsample(cloud, 0.5f).size(), 16u);
}

TEST(VoxelIndexTable, GivesDenseIndicesInInsertionOrderAndGrows) {
  VoxelIndexTable table(4);
  for (uint64_t k = 0; k < 1000; ++k) {
    const auto [index, inserted] = table.insert(k * 7919);
    EXPECT_EQ(index, k);
    EXPECT_TRUE(inserted);
  }
  EXPECT_EQ(table.insert(7919 * 5).first, 5u);
  EXPECT_FALSE(table.insert(7919 * 5).second);
  EXPECT_EQ(table.find(7919 * 999), 999u);
  EXPECT_EQ(table.find(3), VoxelIndexTable::kMissing);
  table.assign({42, 43});
  EXPECT_EQ(table.size(), 2u);
  EXPECT_EQ(table.find(43), 1u);
  EXPECT_EQ(table.find(7919), VoxelIndexTable::kMissing);
}

// Quantized clouds: within half a centimetre and 1/510 of the largest intensity; a cloud
// too large for 1 cm steps in int16 gets coarser steps rather than wrapping around.
TEST(CompactCloud, QuantizesWithinHalfAStep) {
  const float nan = std::nanf("");
  PointCloud cloud;
  cloud.push_back(Eigen::Vector3f(12.3456f, -98.7654f, 0.0049f), 0.0f);
  cloud.push_back(Eigen::Vector3f(-0.001f, 250.0f, -3.2f), 100.0f);
  cloud.push_back(Eigen::Vector3f(1, 2, 3), nan);
  const CompactCloud compact = quantize(cloud);
  EXPECT_FLOAT_EQ(compact.resolution_m, 0.01f);
  const PointCloud back = dequantize(compact);
  ASSERT_EQ(back.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_LE((back.points[i] - cloud.points[i]).cwiseAbs().maxCoeff(), 0.005f + 1e-5f);
  }
  EXPECT_NEAR(back.intensities[1], 100.0f, 1e-3f);
  EXPECT_EQ(back.intensities[2], 0.0f);

  PointCloud far;
  far.push_back(Eigen::Vector3f(1000.0f, -1000.0f, 5.0f), 1.0f);
  const CompactCloud coarse = quantize(far);
  EXPECT_GT(coarse.resolution_m, 0.03f);
  EXPECT_LE((dequantize(coarse).points[0] - far.points[0]).cwiseAbs().maxCoeff(),
            coarse.resolution_m / 2 + 1e-3f);
  far.push_back(Eigen::Vector3f(nan, 0, 0), 1.0f);
  EXPECT_THROW(quantize(far), std::invalid_argument);
}

// A slice keeps the steps, so that its points dequantize as they did in the whole cloud.
TEST(CompactCloud, SliceKeepsStepsAndCheckNamesBadClouds) {
  PointCloud cloud;
  for (int i = 0; i < 5; ++i) {
    cloud.push_back(Eigen::Vector3f(i * 100.0f, 0.5f, -i * 1.0f), static_cast<float>(i));
  }
  const CompactCloud compact = quantize(cloud);
  const CompactCloud middle = slice(compact, 1, 4);
  ASSERT_EQ(middle.size(), 3u);
  EXPECT_EQ(middle.resolution_m, compact.resolution_m);
  const PointCloud all = dequantize(compact);
  const PointCloud part = dequantize(middle);
  const PointCloud range = dequantize(compact, 1, 4);
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(part.points[i], all.points[i + 1]);
    EXPECT_EQ(range.points[i], all.points[i + 1]);
    EXPECT_EQ(part.intensities[i], all.intensities[i + 1]);
  }
  EXPECT_NO_THROW(check_compact_cloud(compact));
  CompactCloud bad = compact;
  bad.resolution_m = 0.0f;
  EXPECT_THROW(check_compact_cloud(bad), std::invalid_argument);
  bad = compact;
  bad.intensity_scale = std::nanf("");
  EXPECT_THROW(check_compact_cloud(bad), std::invalid_argument);
  bad = compact;
  bad.z.pop_back();
  EXPECT_THROW(check_compact_cloud(bad), std::invalid_argument);
}

// A registration source of bounded cost: at most max_points, spread over the whole cloud.
TEST(VoxelGrid, SparsePointsAreCappedAndSpread) {
  PointCloud line;
  for (int i = 0; i < 1000; ++i) {
    line.push_back(Eigen::Vector3f(0.1f * static_cast<float>(i), 0.0f, 0.0f), 1.0f);
  }
  const std::vector<Eigen::Vector3f> few = sparse_points(line, 0.5f, 100);
  EXPECT_EQ(few.size(), 100u);  // 200 voxels, every second
  EXPECT_LT(few.front().x(), 0.5f);
  EXPECT_GT(few.back().x(), 98.0f);
  EXPECT_EQ(sparse_points(line, 0.5f, 1000).size(), 200u);
  // Not a whole divisor of the voxels: still at most max_points, still end to end.
  const std::vector<Eigen::Vector3f> capped = sparse_points(line, 0.5f, 150);
  EXPECT_EQ(capped.size(), 150u);
  EXPECT_GT(capped.back().x(), 98.0f);
}

// Points at 20 m on rays of the given elevations (deg), every 2 degrees of azimuth.
std::vector<LidarPoint> rays_at(const std::vector<double>& elevations_deg) {
  std::vector<LidarPoint> points;
  for (const double el_deg : elevations_deg) {
    const double el = el_deg * M_PI / 180.0;
    for (int az_deg = 0; az_deg < 360; az_deg += 2) {
      const double az = az_deg * M_PI / 180.0;
      LidarPoint p;
      p.position_m = 20.0f * Eigen::Vector3f(static_cast<float>(std::cos(el) * std::cos(az)),
                                             static_cast<float>(std::cos(el) * std::sin(az)),
                                             static_cast<float>(std::sin(el)));
      points.push_back(p);
    }
  }
  return points;
}

TEST(ElevationGap, IsTheRingSpacingNearTheHorizon) {
  // VLP-16: 16 rings 2 degrees apart from -15 to +15.
  std::vector<double> vlp16;
  for (int r = 0; r < 16; ++r) {
    vlp16.push_back(-15.0 + 2.0 * r);
  }
  const std::optional<double> step = largest_elevation_gap_rad(rays_at(vlp16));
  ASSERT_TRUE(step.has_value());
  EXPECT_NEAR(*step * 180.0 / M_PI, 2.0, 1e-3);
  // A ring without returns (blocked, sky) widens the step: never a finer LiDAR than it is.
  std::vector<double> missing = vlp16;
  missing.erase(missing.begin() + 5);  // -5 deg
  EXPECT_NEAR(*largest_elevation_gap_rad(rays_at(missing)) * 180.0 / M_PI, 4.0, 1e-3);
}

TEST(ElevationGap, IsSmallForAPatternThatFillsTheBand) {
  // A non-repetitive pattern: elevations spread through the band, 0.01 degrees apart.
  std::vector<double> filled;
  for (double el = -7.0; el <= 10.0; el += 0.01) {
    filled.push_back(el);
  }
  EXPECT_LT(*largest_elevation_gap_rad(rays_at(filled)) * 180.0 / M_PI, 0.02);
}

TEST(ElevationGap, DoesNotTellFromTooFewOrNearPoints) {
  ElevationGapConfig config;
  config.min_points = 1000;
  EXPECT_FALSE(largest_elevation_gap_rad(rays_at({-3.0, -1.0}), config).has_value());  // 360
  // Within min_range_m a beam's offset from the origin blurs its elevation: not used.
  std::vector<LidarPoint> near = rays_at({-7.0, -5.0, -3.0, -1.0});
  for (LidarPoint& p : near) {
    p.position_m *= 0.2f;  // 4 m
  }
  EXPECT_FALSE(largest_elevation_gap_rad(near).has_value());
  // Non-finite points are skipped, not propagated.
  std::vector<LidarPoint> with_nan = rays_at({-7.0, -5.0, -3.0, -1.0});
  with_nan.front().position_m.x() = std::nanf("");
  EXPECT_NEAR(*largest_elevation_gap_rad(with_nan) * 180.0 / M_PI, 2.0, 1e-3);
}

}  // namespace
}  // namespace liloc
