#include <gtest/gtest.h>

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

}  // namespace
}  // namespace liloc
