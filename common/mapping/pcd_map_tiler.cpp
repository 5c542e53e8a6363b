#include "mapping/pcd_map_tiler.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

namespace liloc {

void PcdTilingConfig::validate() const {
  if (!(cell_m > 0) || !(radius_m >= cell_m) || !std::isfinite(radius_m) ||
      !std::isfinite(height_m) || min_points < 1) {
    throw std::invalid_argument(
        "need cell-m > 0, a finite radius-m >= cell-m, a finite height-m and min-points >= 1");
  }
}

std::vector<Keyframe> tile_point_cloud(const PointCloud& map_cloud, const PcdTilingConfig& config) {
  config.validate();
  using Cell = std::pair<int, int>;
  std::map<Cell, std::vector<size_t>> cells;
  for (size_t i = 0; i < map_cloud.size(); ++i) {
    cells[{static_cast<int>(std::floor(map_cloud.points[i].x() / config.cell_m)),
           static_cast<int>(std::floor(map_cloud.points[i].y() / config.cell_m))}]
        .push_back(i);
  }
  std::vector<Cell> order;
  for (const auto& [cell, indices] : cells) {
    if (static_cast<int>(indices.size()) >= config.min_points) {
      order.push_back(cell);
    }
  }
  std::sort(order.begin(), order.end(), [](const Cell& a, const Cell& b) {
    if (a.first != b.first) {
      return a.first < b.first;
    }
    return (a.first % 2 == 0) ? a.second < b.second : a.second > b.second;
  });

  const int reach = static_cast<int>(std::ceil(config.radius_m / config.cell_m));
  std::vector<Keyframe> keyframes;
  for (const Cell& cell : order) {
    std::vector<float> heights;
    for (const size_t i : cells[cell]) {
      heights.push_back(map_cloud.points[i].z());
    }
    std::nth_element(heights.begin(), heights.begin() + heights.size() / 20, heights.end());
    const Eigen::Vector3d centre((cell.first + 0.5) * config.cell_m,
                                 (cell.second + 0.5) * config.cell_m,
                                 heights[heights.size() / 20] + config.height_m);
    Keyframe kf;
    kf.id = static_cast<int64_t>(keyframes.size());
    kf.utime_us = kf.id;
    kf.T_odom_body.translation() = centre;
    for (int dx = -reach; dx <= reach; ++dx) {
      for (int dy = -reach; dy <= reach; ++dy) {
        const auto it = cells.find({cell.first + dx, cell.second + dy});
        if (it == cells.end()) {
          continue;
        }
        for (const size_t i : it->second) {
          const Eigen::Vector3d p = map_cloud.points[i].cast<double>() - centre;
          if (p.head<2>().norm() <= config.radius_m) {
            kf.cloud_body.push_back(p.cast<float>(), map_cloud.intensities[i]);
          }
        }
      }
    }
    keyframes.push_back(std::move(kf));
  }
  return keyframes;
}

}  // namespace liloc
