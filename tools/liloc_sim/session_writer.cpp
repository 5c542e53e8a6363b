#include "liloc_sim/session_writer.hpp"

#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "bridge/sensor_stream.hpp"
#include "config/yaml_config.hpp"
#include "dataset/tum_trajectory.hpp"
#include "math/se3.hpp"

namespace liloc::tools {
namespace {

void write_manifest(const std::string& path, const sim::SessionPlan& plan,
                    const sim::SimulationConfig& config, const std::string& lidar_model,
                    const sim::LidarSpec& spec, const sim::SessionSimulator& simulator,
                    int64_t start_utime, uint64_t seed, const SessionOutput& out) {
  const sim::SensorRig rig = config.rig.rig();
  YAML::Emitter y;
  y << YAML::BeginMap;
  y << YAML::Key << "format" << YAML::Value << "liloc-sim-session-1";
  y << YAML::Key << "session" << YAML::Value << plan.name;
  y << YAML::Key << "description" << YAML::Value << plan.description;
  y << YAML::Key << "world_kind" << YAML::Value << config.world.kind;
  y << YAML::Key << "world_seed" << YAML::Value << config.world.seed;
  y << YAML::Key << "session_seed" << YAML::Value << seed;
  y << YAML::Key << "day" << YAML::Value << plan.day;
  y << YAML::Key << "initial_pose_known" << YAML::Value << plan.initial_pose_known;
  y << YAML::Key << "robot_id" << YAML::Value << config.robot_id;
  y << YAML::Key << "start_utime" << YAML::Value << start_utime;
  y << YAML::Key << "duration_s" << YAML::Value << out.duration_s;
  y << YAML::Key << "length_m" << YAML::Value << out.length_m;
  y << YAML::Key << "sweeps" << YAML::Value << out.stats.sweeps;
  y << YAML::Key << "points" << YAML::Value << out.stats.points;
  y << YAML::Key << "imu_samples" << YAML::Value << out.stats.imu_samples;
  y << YAML::Key << "files" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "log" << YAML::Value << "session.lcmlog";
  y << YAML::Key << "ground_truth" << YAML::Value << "ground_truth.tum";
  y << YAML::EndMap;
  y << YAML::Key << "channels" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "imu" << YAML::Value << config.robot_id + "." + "IMU";
  y << YAML::Key << "lidar" << YAML::Value << config.robot_id + "." + "LIDAR";
  y << YAML::EndMap;
  y << YAML::Key << "lidar" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "model" << YAML::Value << lidar_model;
  y << YAML::Key << "rays_per_sweep" << YAML::Value << spec.rays_per_sweep();
  y << YAML::Key << "scan_period_s" << YAML::Value << spec.scan_period_s;
  y << YAML::Key << "max_range_m" << YAML::Value << spec.max_range_m;
  y << YAML::Key << "range_noise_m" << YAML::Value << spec.range_noise_m;
  y << YAML::Key << "dropout_probability" << YAML::Value << spec.dropout_probability;
  y << YAML::EndMap;
  const Eigen::Quaterniond q(rig.T_body_lidar.linear());
  const Eigen::Vector3d& t = rig.T_body_lidar.translation();
  y << YAML::Key << "T_body_lidar" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "translation_m" << YAML::Value << YAML::Flow << YAML::BeginSeq << t.x() << t.y()
    << t.z() << YAML::EndSeq;
  y << YAML::Key << "quaternion_wxyz" << YAML::Value << YAML::Flow << YAML::BeginSeq << q.w()
    << q.x() << q.y() << q.z() << YAML::EndSeq;
  y << YAML::EndMap;
  y << YAML::Key << "lidar_time_offset_s" << YAML::Value << rig.lidar_time_offset_s;
  const Eigen::Vector3d& ba = simulator.initial_accel_bias();
  const Eigen::Vector3d& bg = simulator.initial_gyro_bias();
  y << YAML::Key << "initial_accel_bias_mps2" << YAML::Value << YAML::Flow << YAML::BeginSeq
    << ba.x() << ba.y() << ba.z() << YAML::EndSeq;
  y << YAML::Key << "initial_gyro_bias_rps" << YAML::Value << YAML::Flow << YAML::BeginSeq << bg.x()
    << bg.y() << bg.z() << YAML::EndSeq;
  y << YAML::Key << "config" << YAML::Value << YAML::Load(dump_config(config));
  y << YAML::EndMap;
  std::ofstream file(path);
  file << y.c_str() << "\n";
  if (!file) {
    throw std::runtime_error(path + ": cannot write manifest");
  }
}
}  // namespace

SessionOutput write_session(const sim::SimulatedSession& session,
                            const sim::SimulationConfig& config, const std::string& lidar_model,
                            const std::string& directory, int threads, bool show_progress) {
  const sim::SessionPlan& plan = session.plan;
  const int64_t start_utime = session.start_utime;
  const uint64_t seed = session.seed;
  const auto wall_start = std::chrono::steady_clock::now();
  std::filesystem::create_directories(directory);
  SessionOutput out;
  out.directory = directory;
  out.log_path = directory + "/session.lcmlog";
  out.ground_truth_path = directory + "/ground_truth.tum";
  out.manifest_path = directory + "/manifest.yaml";

  const sim::VehicleTrajectory trajectory(*session.world, plan.waypoints, config.motion, seed);
  const sim::LidarSpec spec = sim::lidar_spec(lidar_model);
  const sim::SessionSimulator simulator(*session.world, trajectory, spec, config.rig.rig(),
                                        config.imu, seed, start_utime);
  out.length_m = trajectory.length_m();
  out.duration_s = trajectory.duration_s();

  {
    int last_decile = -1;
    transport::LogWriter log(out.log_path);
    bridge::SensorStreamConfig stream;
    stream.robot_id = config.robot_id;
    stream.sensor_model = lidar_model;
    bridge::SensorStreamWriter writer(log, stream);
    out.stats = simulator.run(
        [&](const ImuSample& s) { writer.write_imu(s); },
        [&](const LidarScan& scan) { writer.write_scan(scan); },
        [&](double fraction) {
          // On a terminal the line updates in place; in a log, a line
          // per 10 %.
          static const bool tty = isatty(fileno(stderr)) != 0;
          const int decile = static_cast<int>(10.0 * fraction);
          if (!show_progress || (!tty && decile == last_decile)) {
            return;
          }
          last_decile = decile;
          const double elapsed =
              std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
          std::fprintf(stderr,
                       tty ? "\r  %s %-7s %-2s %5.1f %%  %6.1f s  ETA %5.0f s "
                           : "  %s %-7s %-2s %5.1f %%  %6.1f s  ETA %5.0f s\n",
                       config.world.kind.c_str(), lidar_model.c_str(), plan.name.c_str(),
                       100.0 * fraction, elapsed,
                       fraction > 0 ? elapsed * (1.0 / fraction - 1.0) : 0.0);
        },
        threads);
  }  // the log is closed (flushed) here
  if (show_progress && isatty(fileno(stderr))) {
    std::fprintf(stderr, "\n");
  }
  write_tum(out.ground_truth_path, simulator.ground_truth(config.ground_truth_rate_hz));
  out.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  out.log_bytes = std::filesystem::file_size(out.log_path);
  write_manifest(out.manifest_path, plan, config, lidar_model, spec, simulator, start_utime, seed,
                 out);
  return out;
}

}  // namespace liloc::tools
