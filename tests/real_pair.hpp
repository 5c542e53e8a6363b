#pragma once
// The real scan pair of ../shared/data/real/fast_gicp_pair (two Velodyne scans, fast_gicp's
// sample): relative.txt takes the source scan onto the target. For the registration and
// initialization tests.

#include <Eigen/Geometry>
#include <fstream>
#include <string>

#include "dataset/pcd_scan_reader.hpp"
#include "pointcloud/point_cloud.hpp"
#include "pointcloud/voxel_grid.hpp"

namespace liloc::test {

struct RealPair {
  std::string dir = std::string(LILOC_SHARED_DATA_DIR) + "/real/fast_gicp_pair/";
  std::string target_pcd = dir + "251370668.pcd";
  std::string source_pcd = dir + "251371071.pcd";

  Eigen::Isometry3d T_target_source() const {
    std::ifstream in(dir + "relative.txt");
    Eigen::Matrix4d m;
    for (int i = 0; i < 16; ++i) {
      in >> m(i / 4, i % 4);
    }
    Eigen::Isometry3d T;
    T.matrix() = m;
    return T;
  }
  // A scan's points, downsampled at voxel_m.
  static PointCloud read(const std::string& path, float voxel_m) {
    const dataset::PcdScan pcd = dataset::read_pcd_scan(path, 0, 0.1f);
    PointCloud cloud;
    for (const LidarPoint& p : pcd.scan.points) {
      cloud.push_back(p.position_m, p.intensity);
    }
    return voxel_downsample(cloud, voxel_m);
  }
};

}  // namespace liloc::test
