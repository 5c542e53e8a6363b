// liloc_map localize: one scan against a map directory, with or without a coarse pose; the
// pose, its uncertainty, the fitness, the candidates it refused and the time. Exit status 0
// if localized, 3 if not (1 for errors, 2 for a bad command line).

#include "liloc_map/map_localize.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "app/program.hpp"
#include "config/yaml_config.hpp"
#include "dataset/kitti_odometry_reader.hpp"
#include "dataset/pcd_scan_reader.hpp"
#include "initializer/map_directory.hpp"
#include "math/so3.hpp"
#include "pointcloud/voxel_grid.hpp"
#include "system/system_config.hpp"

namespace liloc {
namespace {

constexpr double kDeg = 3.141592653589793 / 180.0;

// Three comma-separated numbers ("x,y,yaw" or "roll,pitch,yaw").
Eigen::Vector3d parse_triple(const std::string& text, const char* option) {
  Eigen::Vector3d v;
  char tail = '\0';
  if (std::sscanf(text.c_str(), "%lf,%lf,%lf%c", &v.x(), &v.y(), &v.z(), &tail) != 3 ||
      !v.allFinite()) {
    throw std::invalid_argument(std::string("--") + option +
                                ": expected three numbers a,b,c, got '" + text + "'");
  }
  return v;
}

// The scan's points in the body frame (the config's LiDAR extrinsic, unless the file is in
// the body frame already, and range limits).
PointCloud read_scan(const std::string& path, const OdometryConfig& odometry, bool body_frame) {
  std::vector<LidarPoint> points;
  if (path.size() > 4 && path.compare(path.size() - 4, 4, ".bin") == 0) {
    points = dataset::read_kitti_bin(path);
  } else {
    points = dataset::read_pcd_scan(path, 0, 0.1f).scan.points;
  }
  const Eigen::Isometry3f T_body_lidar =
      body_frame ? Eigen::Isometry3f::Identity() : odometry.T_body_lidar().cast<float>();
  PointCloud cloud;
  for (const LidarPoint& p : points) {
    const float range = p.position_m.norm();
    if (range >= odometry.min_range_m && range <= odometry.max_range_m) {
      cloud.push_back(T_body_lidar * p.position_m, p.intensity);
    }
  }
  return voxel_downsample(cloud, static_cast<float>(odometry.keyframe_voxel_m));
}

void print_pose(const char* label, const Eigen::Isometry3d& T) {
  // R = Rz(yaw) Ry(pitch) Rx(roll), the convention of so3::from_rpy.
  const Eigen::Matrix3d& R = T.linear();
  const double roll = std::atan2(R(2, 1), R(2, 2));
  const double pitch = -std::asin(std::clamp(R(2, 0), -1.0, 1.0));
  const double yaw = so3::yaw(R);
  std::printf("%-16s x %.3f  y %.3f  z %.3f m   roll %.2f  pitch %.2f  yaw %.2f deg\n", label,
              T.translation().x(), T.translation().y(), T.translation().z(), roll / kDeg,
              pitch / kDeg, yaw / kDeg);
}

}  // namespace

int localize_scan(int argc, const char* const* argv) {
  std::vector<std::string> args;
  std::string config_path;  // see kConfigOptionHelp
  std::string coarse_text;
  std::string rpy_text = "0,0,0";
  double sigma_xy_m = 5.0;
  double sigma_yaw_deg = 30.0;
  std::string frame = "lidar";
  CommandLine cli("liloc_map localize",
                  "Localizes one scan (PCD or KITTI .bin) in a map directory: coarse-to-fine from "
                  "--coarse (paper Section IV-B), else a global search. Exit status 0 if "
                  "localized, 3 if not.");
  cli.add_positional("MAP_DIR SCAN", &args, "the map directory and the scan file", 2);
  cli.add_option("coarse", &coarse_text, "x,y,yaw_deg in the map frame: where the scan roughly is");
  cli.add_option("sigma-xy-m", &sigma_xy_m, "the coarse position's uncertainty (1 sigma)");
  cli.add_option("sigma-yaw-deg", &sigma_yaw_deg, "the coarse heading's uncertainty (1 sigma)");
  cli.add_option("rpy-deg", &rpy_text,
                 "roll,pitch,yaw of the sensor's body against gravity (yaw is ignored): a scan "
                 "file does not say which way is down");
  cli.add_option("frame", &frame,
                 "lidar (a sensor's scan: the config's extrinsic applies) or body (a keyframe "
                 "cloud, e.g. a map's keyframes/N.pcd)");
  cli.add_option("config", &config_path, kConfigOptionHelp);
  return run_program(cli, "liloc_map", argc, argv, [&]() -> int {
    const SystemConfig config = load_program_config<SystemConfig>(config_path);
    const auto start = std::chrono::steady_clock::now();
    const OpenedMap map(args[0], config.descriptor, config.map_server.service.reply_voxel_m);
    const MapIndex& index = map.index;
    const SubmapTargets targets(map.points);
    const double load_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    InitQuery query;
    if (frame != "lidar" && frame != "body") {
      throw std::invalid_argument("--frame: lidar or body, got '" + frame + "'");
    }
    query.cloud_body = read_scan(args[1], config.odometry, frame == "body");
    query.T_odom_body.linear() = so3::from_rpy(parse_triple(rpy_text, "rpy-deg") * kDeg);
    const PoseInitializer initializer(config.initializer.search, config.descriptor);
    InitResult result;
    if (coarse_text.empty()) {
      result = initializer.global(index, query, targets);
    } else {
      const Eigen::Vector3d c = parse_triple(coarse_text, "coarse");
      CoarsePose coarse;
      coarse.x_m = c.x();
      coarse.y_m = c.y();
      coarse.yaw_rad = c.z() * kDeg;
      coarse.sigma_xy_m = sigma_xy_m;
      coarse.sigma_yaw_rad = sigma_yaw_deg * kDeg;
      result = initializer.coarse_to_fine(index, query, coarse, targets);
    }

    std::printf("map             %s (version %lld, %zu keyframes, loaded in %.1f s)\n",
                args[0].c_str(), static_cast<long long>(map.data.version), index.keyframes().size(),
                load_s);
    std::printf("scan            %s (%zu points after %.2f m voxels)\n", args[1].c_str(),
                query.cloud_body.size(), config.odometry.keyframe_voxel_m);
    std::printf("method          %s\n", result.method.c_str());
    std::printf("result          %s\n", result.localized() ? "LOCALIZED" : "NOT LOCALIZED");
    std::printf("reason          %s\n", result.reason.c_str());
    if (result.best) {
      const InitCandidate& b = *result.best;
      print_pose("pose (T_map_body)", b.T_map_body);
      const Vector6d sigma = b.covariance.diagonal().cwiseSqrt();
      std::printf("sigma           x %.3f  y %.3f  z %.3f m   rx %.3f  ry %.3f  rz %.3f deg\n",
                  sigma(0), sigma(1), sigma(2), sigma(3) / kDeg, sigma(4) / kDeg, sigma(5) / kDeg);
      std::printf(
          "fitness         %.3f m RMS point-to-plane, %.2f of the points within %.2f m of "
          "the map, %.2f on map planes%s\n",
          b.fitness_m, b.inlier_ratio, config.initializer.search.inlier_m, b.overlap,
          b.degenerate ? ", DEGENERATE" : "");
      std::printf("matched         keyframe %lld in submap %lld, descriptor distance %.3f\n",
                  static_cast<long long>(b.keyframe_id), static_cast<long long>(b.submap_id),
                  b.descriptor_distance);
    }
    std::printf("candidates      %zu\n", result.candidates.size());
    for (const InitCandidate& c : result.candidates) {
      std::printf("  keyframe %-6lld submap %-4lld descriptor %.3f",
                  static_cast<long long>(c.keyframe_id), static_cast<long long>(c.submap_id),
                  c.descriptor_distance);
      if (c.verified) {
        std::printf("  at (%.2f, %.2f)  inliers %.2f  fitness %.3f", c.T_map_body.translation().x(),
                    c.T_map_body.translation().y(), c.inlier_ratio, c.fitness_m);
      }
      std::printf("  %s\n", c.rejected.empty() ? "ANSWER" : c.rejected.c_str());
    }
    std::printf("time            %.0f ms (search and registration; map loading not counted)\n",
                result.time_ms);
    return result.localized() ? 0 : 3;
  });
}

}  // namespace liloc
