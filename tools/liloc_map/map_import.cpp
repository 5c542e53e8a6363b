// Maps from what users already have: scans with known poses, or one global point cloud.

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>

#include "app/program.hpp"
#include "config/yaml_config.hpp"
#include "dataset/dataset_factory.hpp"
#include "dataset/pcd_scan_reader.hpp"
#include "dataset/tum_trajectory.hpp"
#include "liloc_map/map_build.hpp"
#include "math/so3.hpp"
#include "pointcloud/voxel_grid.hpp"

namespace liloc {
namespace {

constexpr const char* kProgram = "liloc_map";

// The builder's view of one keyframe: pose and body-frame cloud.
Keyframe make_keyframe(int64_t id, int64_t utime_us, const Eigen::Isometry3d& T_map_body,
                       PointCloud cloud_body) {
  Keyframe kf;
  kf.id = id;
  kf.utime_us = utime_us;
  kf.T_odom_body = T_map_body;
  kf.cloud_body = std::move(cloud_body);
  return kf;
}

// Known poses need no loop closing; consecutive keyframes are still linked by edges.
CentralSessionBuilder known_pose_builder(const SystemConfig& config, const std::string& session) {
  CentralSessionConfig builder_config = central_session_config(config);
  builder_config.close_loops = false;
  builder_config.session = session;
  return CentralSessionBuilder(builder_config);
}

}  // namespace

int build_map_from_poses(int argc, const char* const* argv) {
  std::vector<std::string> args;
  std::string config_path = "config/liloc.yaml";
  std::string format = "folder";
  std::string sequence;
  std::string poses_path;
  std::string map_id = "liloc-map";
  CommandLine cli("liloc_map build-from-poses",
                  "Builds a map directory from LiDAR scans with known poses: a KITTI odometry "
                  "sequence with its poses, or a folder of PCD scans with a TUM trajectory. "
                  "A scan becomes a keyframe every 1 m or 0.2 rad (odometry config).");
  cli.add_positional("DATASET OUT_DIR", &args, "the dataset and the new map directory", 2);
  cli.add_option("format", &format, "kitti or folder (see docs/datasets.md)");
  cli.add_option("sequence", &sequence, "KITTI sequence (default 00)");
  cli.add_option("poses", &poses_path,
                 "TUM file of T_world_body at the scans' times (default: the dataset's own)");
  cli.add_option("config", &config_path, "system config (YAML)");
  cli.add_option("map-id", &map_id, "the map's id");
  return run_program(cli, kProgram, argc, argv, [&]() -> int {
    const SystemConfig config = load_config<SystemConfig>(config_path);
    require_new_map_directory(args[1]);
    std::unique_ptr<dataset::SensorDatasetReader> reader =
        dataset::open_dataset(format, args[0], sequence, {});
    const Trajectory poses = poses_path.empty() ? reader->ground_truth() : read_tum(poses_path);
    if (poses.empty()) {
      throw std::invalid_argument(args[0] + " has no poses: pass --poses FILE.tum");
    }
    const Eigen::Isometry3d T_body_lidar =
        reader->sensor_setup().T_body_lidar.value_or(Eigen::Isometry3d::Identity());
    const OdometryConfig& odometry = config.odometry;

    CentralSessionBuilder builder = known_pose_builder(config, "poses");
    std::optional<Eigen::Isometry3d> last;
    int64_t scans = 0, without_pose = 0, keyframes = 0;
    dataset::SensorEvent event;
    while (reader->next(event)) {
      const LidarScan* scan = std::get_if<LidarScan>(&event);
      if (scan == nullptr) {
        continue;
      }
      ++scans;
      const std::optional<Eigen::Isometry3d> T_map_body = poses.at(scan->utime_us * 1e-6, 0.5);
      if (!T_map_body) {
        ++without_pose;
        continue;
      }
      if (last) {
        const Eigen::Isometry3d step = last->inverse() * *T_map_body;
        if (step.translation().norm() < odometry.keyframe_translation_m &&
            so3::log(step.linear()).norm() < odometry.keyframe_rotation_rad) {
          continue;
        }
      }
      PointCloud cloud;
      cloud.reserve(scan->points.size());
      for (const LidarPoint& p : scan->points) {
        const double range = p.position_m.norm();
        if (range >= odometry.min_range_m && range <= odometry.max_range_m) {
          cloud.points.push_back((T_body_lidar * p.position_m.cast<double>()).cast<float>());
          cloud.intensities.push_back(p.intensity);
        }
      }
      builder.add(
          make_keyframe(keyframes++, scan->utime_us, *T_map_body,
                        voxel_downsample(cloud, static_cast<float>(odometry.keyframe_voxel_m))));
      last = T_map_body;
    }
    if (keyframes == 0) {
      throw std::invalid_argument(args[0] + ": no scan has a pose (" + std::to_string(scans) +
                                  " scans, none within the trajectory's time span)");
    }
    CentralSessionReport report;
    save_built_map(builder, config, args[1], map_id, &report);
    std::printf("scans           %lld read, %lld without a pose\n", static_cast<long long>(scans),
                static_cast<long long>(without_pose));
    return 0;
  });
}

int build_map_from_pcd(int argc, const char* const* argv) {
  std::vector<std::string> args;
  std::string config_path = "config/liloc.yaml";
  std::string map_id = "liloc-map";
  double cell_m = 20.0;
  double radius_m = 30.0;
  double height_m = 1.8;
  int min_points = 200;
  CommandLine cli("liloc_map build-from-pcd",
                  "Builds a map directory from one point-cloud map (PCD, map frame): "
                  "pseudo-keyframes on an xy grid, each holding the points within a radius, so "
                  "that robots can localize against a map they did not record with liloc.");
  cli.add_positional("MAP_PCD OUT_DIR", &args, "the point cloud and the new map directory", 2);
  cli.add_option("cell-m", &cell_m, "grid spacing of the pseudo-keyframes, metres");
  cli.add_option("radius-m", &radius_m, "points within this xy distance go to a keyframe");
  cli.add_option("height-m", &height_m, "keyframe height above the cell's lowest points");
  cli.add_option("min-points", &min_points, "cells with fewer points get no keyframe");
  cli.add_option("config", &config_path, "system config (YAML)");
  cli.add_option("map-id", &map_id, "the map's id");
  return run_program(cli, kProgram, argc, argv, [&]() -> int {
    if (!(cell_m > 0) || !(radius_m >= cell_m)) {
      throw std::invalid_argument("need cell-m > 0 and radius-m >= cell-m");
    }
    const SystemConfig config = load_config<SystemConfig>(config_path);
    require_new_map_directory(args[1]);
    const PointCloud all = [&] {
      const LidarScan scan = dataset::read_pcd_scan(args[0], 0, 0.1f).scan;
      PointCloud cloud;
      cloud.reserve(scan.points.size());
      for (const LidarPoint& p : scan.points) {
        cloud.points.push_back(p.position_m);
        cloud.intensities.push_back(p.intensity);
      }
      return voxel_downsample(cloud, static_cast<float>(config.odometry.keyframe_voxel_m));
    }();
    if (all.empty()) {
      throw std::invalid_argument(args[0] + ": no points");
    }

    // Points by grid cell; a keyframe per occupied cell, in serpentine order so that
    // consecutive keyframes are neighbours and Eq. 2 joins compact submaps.
    using Cell = std::pair<int, int>;
    std::map<Cell, std::vector<size_t>> cells;
    for (size_t i = 0; i < all.size(); ++i) {
      cells[{static_cast<int>(std::floor(all.points[i].x() / cell_m)),
             static_cast<int>(std::floor(all.points[i].y() / cell_m))}]
          .push_back(i);
    }
    std::vector<Cell> order;
    for (const auto& [cell, indices] : cells) {
      if (static_cast<int>(indices.size()) >= min_points) {
        order.push_back(cell);
      }
    }
    std::sort(order.begin(), order.end(), [](const Cell& a, const Cell& b) {
      if (a.first != b.first) {
        return a.first < b.first;
      }
      return (a.first % 2 == 0) ? a.second < b.second : a.second > b.second;
    });

    const int reach = static_cast<int>(std::ceil(radius_m / cell_m));
    CentralSessionBuilder builder = known_pose_builder(config, "pcd");
    int64_t keyframes = 0;
    for (const Cell& cell : order) {
      // The ground of the cell: a low percentile of its heights.
      std::vector<float> heights;
      for (const size_t i : cells[cell]) {
        heights.push_back(all.points[i].z());
      }
      std::nth_element(heights.begin(), heights.begin() + heights.size() / 20, heights.end());
      const Eigen::Vector3d centre((cell.first + 0.5) * cell_m, (cell.second + 0.5) * cell_m,
                                   heights[heights.size() / 20] + height_m);
      Eigen::Isometry3d T_map_body = Eigen::Isometry3d::Identity();
      T_map_body.translation() = centre;
      PointCloud cloud_body;
      for (int dx = -reach; dx <= reach; ++dx) {
        for (int dy = -reach; dy <= reach; ++dy) {
          const auto it = cells.find({cell.first + dx, cell.second + dy});
          if (it == cells.end()) {
            continue;
          }
          for (const size_t i : it->second) {
            const Eigen::Vector3d p = all.points[i].cast<double>() - centre;
            if (p.head<2>().norm() <= radius_m) {
              cloud_body.points.push_back(p.cast<float>());
              cloud_body.intensities.push_back(all.intensities[i]);
            }
          }
        }
      }
      builder.add(make_keyframe(keyframes, keyframes, T_map_body, std::move(cloud_body)));
      ++keyframes;
    }
    if (keyframes == 0) {
      throw std::invalid_argument(args[0] + ": no grid cell has " + std::to_string(min_points) +
                                  " points (lower --min-points or raise --cell-m)");
    }
    CentralSessionReport report;
    save_built_map(builder, config, args[1], map_id, &report);
    std::printf("points          %zu after %.2f m voxels, %zu grid cells of %.1f m\n", all.size(),
                config.odometry.keyframe_voxel_m, cells.size(), cell_m);
    return 0;
  });
}

}  // namespace liloc
