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
#include "mapping/pcd_map_tiler.hpp"
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

}  // namespace

int build_map_from_poses(int argc, const char* const* argv) {
  std::vector<std::string> args;
  std::string config_path;  // see kConfigOptionHelp
  std::string format = "folder";
  std::string sequence;
  std::string poses_path;
  std::string map_id = "liloc-map";
  double max_gap_s = kReferencePoseMaxGapS;
  double tolerance_s = 1e-3;  // a scan this close to a pose takes it
  CommandLine cli("liloc_map build-from-poses",
                  "Builds a map directory from LiDAR scans with known poses: a KITTI odometry "
                  "sequence with its poses, or a folder of PCD scans with a TUM trajectory. "
                  "A scan becomes a keyframe every 1 m or 0.2 rad (odometry config).");
  cli.add_positional("DATASET OUT_DIR", &args, "the dataset and the new map directory", 2);
  cli.add_option("format", &format, "kitti or folder (see docs/datasets.md)");
  cli.add_option("sequence", &sequence, "KITTI sequence (default 00)");
  cli.add_option("poses", &poses_path,
                 "TUM file of T_world_body at the scans' times (default: the dataset's own)");
  cli.add_option("max-gap-s", &max_gap_s,
                 "interpolate between poses at most this far apart, seconds");
  cli.add_option("time-tolerance-s", &tolerance_s,
                 "a scan within this of a pose's time takes that pose, seconds");
  cli.add_option("config", &config_path, kConfigOptionHelp);
  cli.add_option("map-id", &map_id, "the map's id");
  return run_program(cli, kProgram, argc, argv, [&]() -> int {
    if (!(max_gap_s > 0) || !(tolerance_s >= 0)) {
      throw std::invalid_argument("--max-gap-s must be positive, --time-tolerance-s not negative");
    }
    const SystemConfig config = load_program_config<SystemConfig>(config_path);
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

    // Known poses need no loop closing; consecutive keyframes are still linked by edges.
    CentralSessionBuilder builder = central_session_builder(config, "poses", false);
    std::optional<Eigen::Isometry3d> last;
    int64_t scans = 0, keyframes = 0;
    std::map<TrajectoryCoverage, std::vector<double>> without_pose;  // scan times by reason
    double widest_gap_s = 0.0;
    dataset::SensorEvent event;
    while (reader->next(event)) {
      const LidarScan* scan = std::get_if<LidarScan>(&event);
      if (scan == nullptr) {
        continue;
      }
      ++scans;
      const double time_s = scan->utime_us * 1e-6;
      const TrajectoryLookup pose = poses.lookup(time_s, max_gap_s, tolerance_s);
      if (!pose.T) {
        without_pose[pose.coverage].push_back(time_s);
        widest_gap_s = std::max(widest_gap_s, pose.gap_s);
        continue;
      }
      const Eigen::Isometry3d& T_map_body = *pose.T;
      if (last) {
        const Eigen::Isometry3d step = last->inverse() * T_map_body;
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
          make_keyframe(keyframes++, scan->utime_us, T_map_body,
                        voxel_downsample(cloud, static_cast<float>(odometry.keyframe_voxel_m))));
      last = T_map_body;
    }
    if (keyframes == 0) {
      throw std::invalid_argument(args[0] + ": no scan has a pose (" + std::to_string(scans) +
                                  " scans, none within the trajectory's time span)");
    }
    CentralSessionReport report;
    save_built_map(builder, config, args[1], map_id, &report);
    size_t missing = 0;
    for (const auto& [coverage, times] : without_pose) {
      missing += times.size();
    }
    std::printf("scans           %lld read, %zu without a pose\n", static_cast<long long>(scans),
                missing);
    for (const auto& [coverage, times] : without_pose) {
      const std::string why =
          coverage == TrajectoryCoverage::kBeforeStart ? "before the poses' first time"
          : coverage == TrajectoryCoverage::kAfterEnd
              ? "after the poses' last time"
              : fmt::format("between poses up to {:.2f} s apart (--max-gap-s {:.2f})", widest_gap_s,
                            max_gap_s);
      spdlog::warn("{} scan(s) {}: first at {:.6f} s, last at {:.6f} s", times.size(), why,
                   times.front(), times.back());
    }
    return 0;
  });
}

int build_map_from_pcd(int argc, const char* const* argv) {
  std::vector<std::string> args;
  std::string config_path;  // see kConfigOptionHelp
  std::string map_id = "liloc-map";
  PcdTilingConfig tiling;
  CommandLine cli("liloc_map build-from-pcd",
                  "Builds a map directory from one point-cloud map (PCD, map frame): "
                  "pseudo-keyframes on an xy grid, each holding the points within a radius, so "
                  "that robots can localize against a map they did not record with liloc.");
  cli.add_positional("MAP_PCD OUT_DIR", &args, "the point cloud and the new map directory", 2);
  cli.add_option("cell-m", &tiling.cell_m, "grid spacing of the pseudo-keyframes, metres");
  cli.add_option("radius-m", &tiling.radius_m, "points within this xy distance go to a keyframe");
  cli.add_option("height-m", &tiling.height_m, "keyframe height above the cell's lowest points");
  cli.add_option("min-points", &tiling.min_points, "cells with fewer points get no keyframe");
  cli.add_option("config", &config_path, kConfigOptionHelp);
  cli.add_option("map-id", &map_id, "the map's id");
  return run_program(cli, kProgram, argc, argv, [&]() -> int {
    tiling.validate();
    const SystemConfig config = load_program_config<SystemConfig>(config_path);
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

    CentralSessionBuilder builder = central_session_builder(config, "pcd", false);
    const std::vector<Keyframe> keyframes = tile_point_cloud(all, tiling);
    for (const Keyframe& kf : keyframes) {
      builder.add(kf);
    }
    if (keyframes.empty()) {
      throw std::invalid_argument(args[0] + ": no grid cell has " +
                                  std::to_string(tiling.min_points) +
                                  " points (lower --min-points or raise --cell-m)");
    }
    CentralSessionReport report;
    save_built_map(builder, config, args[1], map_id, &report);
    std::printf("points          %zu after %.2f m voxels, %zu keyframes on a %.1f m grid\n",
                all.size(), config.odometry.keyframe_voxel_m, keyframes.size(), tiling.cell_m);
    return 0;
  });
}

}  // namespace liloc
