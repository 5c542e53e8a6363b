#include "liloc_map/map_build.hpp"

#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <optional>

#include "app/program.hpp"
#include "config/yaml_config.hpp"
#include "dataset/tum_trajectory.hpp"
#include "eval/json_writer.hpp"
#include "eval/trajectory_metrics.hpp"
#include "map/keyframe_descriptors.hpp"
#include "math/so3.hpp"
#include "odometry_node/log_drive.hpp"
#include "storage/map_store.hpp"
#include "storage/submap_cloud_files.hpp"
#include "system/system_config.hpp"
#include "transport/log_file.hpp"
#include "transport/transport.hpp"

namespace liloc {

void require_new_map_directory(const std::string& directory) {
  if (storage::MapStore(directory).exists()) {
    throw std::invalid_argument(directory + " already holds a map; choose a new directory");
  }
}

namespace {

Trajectory keyframe_trajectory(const std::vector<MapKeyframe>& keyframes) {
  std::vector<StampedPose> poses;
  poses.reserve(keyframes.size());
  for (const MapKeyframe& kf : keyframes) {
    poses.push_back({kf.utime_us * 1e-6, kf.T_map_body});
  }
  return Trajectory(std::move(poses));
}

// Runs the odometry over a recorded drive, keyframes into the builder.
struct DriveResult {
  std::vector<MapKeyframe> odometry_keyframes;  // as the odometry had them (before loops)
  OdometryCounters counters;
  int64_t scans = 0;
  std::vector<int64_t> without_reference;  // keyframe times (us) the reference did not cover
};

// With a reference trajectory, each keyframe keeps the odometry's deskewed cloud but takes
// its pose from the reference; keyframes outside the reference are left out.
DriveResult run_odometry(const SystemConfig& config, const std::string& log_path,
                         const std::string& robot_id, const std::optional<Trajectory>& reference,
                         CentralSessionBuilder& builder) {
  DriveResult drive;
  const LogDrive run = run_odometry_on_log(
      log_path, robot_id, config.odometry_node(), config.transport, [&](const Keyframe& keyframe) {
        if (!reference) {
          builder.add(keyframe);
        } else if (const std::optional<Eigen::Isometry3d> T_world_body =
                       reference->at(keyframe.utime_us * 1e-6, kReferencePoseMaxGapS)) {
          Keyframe posed = keyframe;
          posed.T_odom_body = *T_world_body;
          posed.gravity_body.setZero();  // reference poses are kept as they are, not levelled
          builder.add(posed);
        } else {
          drive.without_reference.push_back(keyframe.utime_us);
        }
        MapKeyframe kf;
        kf.utime_us = keyframe.utime_us;
        kf.T_map_body = keyframe.T_odom_body;
        drive.odometry_keyframes.push_back(kf);
        if (drive.odometry_keyframes.size() % 200 == 0) {
          spdlog::info("{} keyframes", drive.odometry_keyframes.size());
        }
      });
  if (run.damage.any()) {
    // A map must not be built from part of a drive without saying so.
    throw std::runtime_error(log_path + ": damaged log (" + run.damage.summary() +
                             "); no map built");
  }
  drive.scans = run.sweeps;
  drive.counters = run.counters;
  if (reference && drive.odometry_keyframes.size() == drive.without_reference.size()) {
    throw std::runtime_error("none of the " + std::to_string(drive.without_reference.size()) +
                             " keyframes of " + log_path +
                             " lies within the reference poses' time span");
  }
  if (drive.odometry_keyframes.empty()) {
    throw std::runtime_error("no keyframes from " + log_path + ": does it hold " +
                             transport::robot_channel(robot_id, config.channels.lidar) + " and " +
                             transport::robot_channel(robot_id, config.channels.imu) + "?");
  }
  return drive;
}

// The deduplicated reply clouds of every submap, so that the server need not compute them.
void save_submap_clouds(const std::string& directory, const MapData& map,
                        const std::map<int64_t, PointCloud>& clouds, const SystemConfig& config) {
  fill_submap_cloud_store(
      map,
      // Borrowed, not owned: `clouds` outlives the fill.
      [&clouds](int64_t id) {
        return std::shared_ptr<const PointCloud>(&clouds.at(id), [](const PointCloud*) {});
      },
      storage::SubmapCloudFiles(directory, config.map_server.service.reply_voxel_m));
}

}  // namespace

MapData save_built_map(CentralSessionBuilder& builder, const SystemConfig& config,
                       const std::string& directory, const std::string& map_id,
                       CentralSessionReport* report) {
  std::map<int64_t, PointCloud> clouds;
  MapData map = builder.build(&clouds, report);
  map.map_id = map_id;
  storage::MapStore(directory).save(
      map, clouds, encode_keyframe_descriptors(map.keyframes, clouds, config.descriptor));
  save_submap_clouds(directory, map, clouds, config);
  print_map_summary(directory, map, *report);
  return map;
}

CentralSessionBuilder central_session_builder(const SystemConfig& config,
                                              const std::string& session, bool close_loops) {
  CentralSessionConfig builder = config.map_builder;
  builder.session = session;
  builder.close_loops = builder.close_loops && close_loops;
  return CentralSessionBuilder(builder, config.submaps, config.descriptor);
}

void print_map_summary(const std::string& directory, const MapData& map,
                       const CentralSessionReport& report) {
  std::printf("map             %s (version %lld)\n", directory.c_str(),
              static_cast<long long>(map.version));
  std::printf("keyframes       %zu in %zu submaps\n", report.keyframes, report.submaps);
  std::printf("loop closures   %zu\n", report.loop_closures);
  if (report.graph.gravity_factors > 0) {
    std::printf(
        "levelled        by gravity at %d keyframes, largest tilt %.1f -> %.1f mrad; the frame "
        "turned %.2f deg to put z up\n",
        report.graph.gravity_factors, 1e3 * report.graph.max_tilt_before_rad,
        1e3 * report.graph.max_tilt_after_rad, report.graph.frame_turn_rad * so3::kRadToDeg);
  }
}

int build_map(int argc, const char* const* argv) {
  std::vector<std::string> args;
  std::string config_path;  // see kConfigOptionHelp
  std::string robot_id = "robot0";
  std::string ground_truth_path;
  std::string json_path;
  std::string map_id = "liloc-map";
  std::string poses_path;
  bool no_loops = false;
  CommandLine cli("liloc_map build",
                  "Builds a map directory (the central session) from a recorded drive: "
                  "odometry, keyframes, loop closures, pose-graph optimization, submaps.");
  cli.add_positional("LOG OUT_DIR", &args, "the drive's LCM log and the new map directory", 2);
  cli.add_option("config", &config_path, kConfigOptionHelp);
  cli.add_option("robot", &robot_id, "robot id: the prefix of the log's channels");
  cli.add_option("ground-truth", &ground_truth_path, "TUM file: report the map's ATE");
  cli.add_option("json", &json_path, "write the report as JSON here");
  cli.add_option("map-id", &map_id, "the map's id");
  cli.add_flag("no-loops", &no_loops, "odometry only: do not close loops");
  cli.add_option("poses", &poses_path,
                 "TUM file of T_world_body (RTK/INS, a simulator's truth): the keyframes take "
                 "their poses from it instead of the odometry, no loops are closed, the map "
                 "frame is its world frame");
  return run_program(cli, "liloc_map", argc, argv, [&]() -> int {
    const SystemConfig config = load_program_config<SystemConfig>(config_path);
    require_new_map_directory(args[1]);
    std::optional<Trajectory> ground_truth;
    if (!ground_truth_path.empty()) {
      ground_truth = read_tum(ground_truth_path);  // fail early on a bad file
    }
    std::optional<Trajectory> reference;
    if (!poses_path.empty()) {
      reference = read_tum(poses_path);
      if (reference->empty()) {
        throw std::invalid_argument(poses_path + " holds no poses");
      }
    }

    const auto start = std::chrono::steady_clock::now();
    CentralSessionBuilder builder =
        central_session_builder(config, config.map_builder.session, !no_loops && !reference);
    const DriveResult drive = run_odometry(config, args[0], robot_id, reference, builder);
    if (!drive.without_reference.empty()) {
      spdlog::warn(
          "{} of {} keyframes left out: {} has no poses at most {} s apart around them "
          "(first at {:.3f} s, last at {:.3f} s)",
          drive.without_reference.size(), drive.odometry_keyframes.size(), poses_path,
          kReferencePoseMaxGapS, drive.without_reference.front() * 1e-6,
          drive.without_reference.back() * 1e-6);
    }
    const double odometry_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    CentralSessionReport report;
    MapData map = save_built_map(builder, config, args[1], map_id, &report);
    const double total_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    std::printf("sweeps          %lld (odometry %.1f s, total %.1f s)\n",
                static_cast<long long>(drive.scans), odometry_s, total_s);
    double ate_odometry = -1.0, ate_map = -1.0, up_error_deg = -1.0;
    if (ground_truth) {
      eval::EvalConfig eval_config;
      ate_odometry = eval::evaluate_trajectory(
                         *ground_truth, keyframe_trajectory(drive.odometry_keyframes), eval_config)
                         .ate_position_rmse_m;
      const eval::TrajectoryMetrics fit =
          eval::evaluate_trajectory(*ground_truth, keyframe_trajectory(map.keyframes), eval_config);
      ate_map = fit.ate_position_rmse_m;
      // The truth's z is up: how far the map's z is from it, by the alignment's rotation.
      up_error_deg = so3::tilt(fit.T_gt_est.linear()) * so3::kRadToDeg;
      std::printf(
          "ATE keyframes   %.3f m odometry only, %.3f m map (SE(3)-aligned); the map's z "
          "%.2f deg from the truth's up\n",
          ate_odometry, ate_map, up_error_deg);
    }
    if (!json_path.empty()) {
      eval::JsonWriter json;
      json.begin_object()
          .key("map")
          .string(args[1])
          .key("keyframes")
          .integer(static_cast<int64_t>(report.keyframes))
          .key("submaps")
          .integer(static_cast<int64_t>(report.submaps))
          .key("loop_closures")
          .integer(static_cast<int64_t>(report.loop_closures))
          .key("gravity_factors")
          .integer(report.graph.gravity_factors)
          .key("odometry_ate_m")
          .number(ate_odometry)
          .key("map_ate_m")
          .number(ate_map)
          .key("up_error_deg")
          .number(up_error_deg)
          .key("build_s")
          .number(total_s)
          .end_object();
      std::ofstream out(json_path);
      out << json.str() << "\n";
      if (!out) {
        throw std::runtime_error("cannot write " + json_path);
      }
    }
    return 0;
  });
}

}  // namespace liloc
