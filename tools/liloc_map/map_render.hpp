#pragma once
// Top-down (x-y) image of a map: the points (coloured by height, or grey), the keyframe
// path of each session, the submaps' bounds with their ids, a scale bar and a legend.
// Points are added cloud by cloud into a raster of the image's resolution, so a map of
// any number of keyframes is drawn without holding its clouds.

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "map/map_types.hpp"
#include "pointcloud/point_cloud.hpp"
#include "pointcloud/voxel_index_table.hpp"

namespace liloc::tools {

struct MapRenderConfig {
  double px_per_m = 2.0;
  bool height_colours = true;  // false: grey points
  int max_side_px = 16000;     // refuses to draw larger images

  // Throws std::invalid_argument naming the value if out of range.
  void validate() const;
};

class MapRenderer {
 public:
  explicit MapRenderer(const MapRenderConfig& config);

  // Adds a cloud given in the body frame of a keyframe at T_map_body.
  void add_cloud(const PointCloud& cloud_body, const Eigen::Isometry3d& T_map_body);

  // Draws the points added so far with the map's paths and submaps. Throws
  // std::invalid_argument if there is nothing to draw or the image would be too large.
  cv::Mat render(const MapData& map, const std::string& title) const;

 private:
  struct Cell {
    int x;
    int y;
    float max_z_m;
  };

  MapRenderConfig config_;
  VoxelIndexTable cell_index_;
  std::vector<Cell> cells_;  // by index in cell_index_
};

}  // namespace liloc::tools
