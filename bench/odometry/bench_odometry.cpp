// bench_odometry: the LiDAR-inertial odometry over simulated sessions (every LiDAR
// model, campus and corridor). Each session is simulated in memory and fed to the
// odometry as the process would receive it; the estimate is scored against ground truth.
// With --imu on,off and --timing regular,irregular it runs each session with and without
// the IMU, with every sweep and with sweeps dropped (gaps up to 5 s; --drop-seeds runs
// several random drop patterns, whose ATE differs by the few sweeps after the longest
// gaps); --world-seed draws another town; --misconfig simulates a rig that differs from
// the configuration (the LiDAR yawed 90 degrees, or its clock 20 ms late) and records what
// the extrinsic check said, or a miscalibrated LiDAR unit (its beams off their nominal
// angles and ranges: the driver's calibration is not the unit's); --imu-fault offsets the
// accelerometer or gyro for a while (a bias step, a faulty IMU).
// Prints a table and writes bench/results/odometry.json with, per run:
// session, world, world_seed, lidar, imu, sweeps, rpe_percent, ate_m, ms_median, ms_p99,
// peak_rss_mb, ...

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>

#include "app/process_memory.hpp"
#include "app/program.hpp"
#include "config/yaml_config.hpp"
#include "eval/json_writer.hpp"
#include "eval/latency_stats.hpp"
#include "eval/trajectory_metrics.hpp"
#include "math/so3.hpp"
#include "odometry/lidar_inertial_odometry.hpp"
#include "sim/lidar_model.hpp"
#include "sim/session_recipe.hpp"
#include "sim/simulation_config.hpp"
#include "storage/file_io.hpp"

namespace {
using namespace liloc;

// Which sweeps reach the odometry: all, or (irregular) a third dropped at random and,
// about every 20 s, a gap of 1-5 s, as a lossy link or a rate-filtered log gives them.
class SweepDropper {
 public:
  SweepDropper(bool irregular, uint64_t seed) : irregular_(irregular), rng_(seed) {}
  bool keep(int64_t utime_us) {
    if (!irregular_) {
      return true;
    }
    if (utime_us < gap_end_us_) {
      return false;
    }
    std::uniform_real_distribution<double> u(0.0, 1.0);
    if (u(rng_) < 0.005) {  // at 10 Hz: one gap per 20 s
      const int64_t gap_us = static_cast<int64_t>((1.0 + 4.0 * u(rng_)) * 1e6);
      gap_end_us_ = utime_us + gap_us;
      longest_gap_s_ = std::max(longest_gap_s_, gap_us * 1e-6);
      return false;
    }
    return u(rng_) >= 1.0 / 3.0;
  }
  double longest_gap_s() const { return longest_gap_s_; }

 private:
  bool irregular_;
  std::mt19937_64 rng_;
  int64_t gap_end_us_ = 0;
  double longest_gap_s_ = 0.0;
};

struct Run {
  std::string world, lidar, session;
  bool use_imu = true;
  int64_t world_seed = 1;
  bool irregular = false;
  int drop_seed = 0;  // which random drop pattern (irregular only)
  std::string misconfig = "none";
  std::string extrinsic_check;  // the check's message, and when it came (s after the start)
  double extrinsic_check_at_s = -1.0;
  bool extrinsic_warned = false;
  std::string ring_adaptation;  // what the odometry chose for the LiDAR's elevation steps
  double longest_gap_s = 0.0;
  int64_t sweeps_used = 0;
  eval::TrajectoryMetrics metrics;
  eval::LatencyStats latency;
  // Median per-stage milliseconds: preprocess, propagate + deskew, register, map, keyframe.
  std::array<double, 5> stage_median_ms{};
  double peak_rss_mb = 0.0;
  double rss_quarter_mb = 0.0;
  double rss_end_mb = 0.0;
  size_t map_points = 0;
  OdometryCounters counters;  // the odometry's, at the session's end
  std::string imu_fault = "none";
  double accel_bias_error = 0.0;
  double gyro_bias_error = 0.0;
};

// An IMU that goes wrong for a while: its accelerometer's x (m/s^2) or its gyro's z
// (rad/s) offset by `magnitude` from start_s to start_s + duration_s into the session.
struct ImuFault {
  std::string kind = "none";  // none, accel or gyro
  double magnitude = 0.0;
  double start_s = 0.0;
  double duration_s = 0.0;

  std::string describe() const {
    char text[96];
    std::snprintf(text, sizeof(text), "%s %+g %s from %g s for %g s", kind.c_str(), magnitude,
                  kind == "accel" ? "m/s^2" : "rad/s", start_s, duration_s);
    return kind == "none" ? "none" : text;
  }
  void apply(ImuSample& sample, int64_t session_start_utime) const {
    const double t = (sample.utime_us - session_start_utime) * 1e-6;
    if (kind == "none" || t < start_s || t >= start_s + duration_s) {
      return;
    }
    if (kind == "accel") {
      sample.accel_mps2.x() += magnitude;
    } else {
      sample.gyro_rps.z() += magnitude;
    }
  }
};

ImuFault parse_imu_fault(const std::string& text) {
  ImuFault fault;
  const std::vector<std::string> parts = split_list(text);
  if (text == "none") {
    return fault;
  }
  if (parts.size() != 4 || (parts[0] != "accel" && parts[0] != "gyro")) {
    throw std::invalid_argument(
        "--imu-fault takes none or accel|gyro,magnitude,start_s,duration_s: " + text);
  }
  fault.kind = parts[0];
  fault.magnitude = std::stod(parts[1]);
  fault.start_s = std::stod(parts[2]);
  fault.duration_s = std::stod(parts[3]);
  if (!std::isfinite(fault.magnitude) || !(fault.start_s >= 0) || !(fault.duration_s > 0)) {
    throw std::invalid_argument("--imu-fault: finite magnitude, start >= 0, duration > 0: " + text);
  }
  return fault;
}

Run run_session(const std::string& world_kind, const std::string& lidar, const std::string& session,
                bool use_imu, double length_scale, int trace, bool clean_imu,
                const std::string& config_path, int64_t world_seed, bool irregular, int drop_seed,
                const std::string& misconfig, const Eigen::Vector3d& beam_errors,
                const ImuFault& imu_fault) {
  sim::SimulationConfig sim_config;
  sim_config.world.kind = world_kind;
  sim_config.world.seed = world_seed;
  sim::scale_session_lengths(sim_config.sessions, length_scale);
  const sim::SimulatedSessions simulated(sim_config);
  const sim::SimulatedSession recipe = simulated.session(session);
  const sim::World& world = *recipe.world;
  const uint64_t seed = recipe.seed;
  const sim::VehicleTrajectory trajectory(world, recipe.plan.waypoints, sim_config.motion, seed);
  if (clean_imu) {
    sim_config.imu.accel_noise_density = sim_config.imu.gyro_noise_density = 1e-9;
    sim_config.imu.accel_bias_random_walk = sim_config.imu.gyro_bias_random_walk = 0.0;
    sim_config.imu.initial_accel_bias_sigma_mps2 = sim_config.imu.initial_gyro_bias_sigma_rps = 0.0;
  }
  // The rig as simulated; the odometry is configured with sim_config.rig.
  sim::RigConfig simulated_rig = sim_config.rig;
  if (misconfig == "extrinsic") {
    simulated_rig.lidar_rpy_deg.z() += 90.0;
  } else if (misconfig == "clock") {
    simulated_rig.lidar_time_offset_s += 0.02;
  } else if (misconfig == "beams") {
    simulated_rig.beam_range_bias_sigma_m = beam_errors.x();
    simulated_rig.beam_elevation_sigma_deg = beam_errors.y();
    simulated_rig.beam_azimuth_sigma_deg = beam_errors.z();
    simulated_rig.validate();
  }
  const sim::SensorRig rig = simulated_rig.rig();
  const sim::SessionSimulator simulator(world, trajectory, sim::lidar_spec(lidar), rig,
                                        sim_config.imu, seed, recipe.start_utime);

  OdometryConfig config =
      config_path.empty() ? OdometryConfig{} : load_config<OdometryConfig>(config_path, "odometry");
  config.use_imu = use_imu;
  config.lidar_translation_m = sim_config.rig.lidar_translation_m;
  config.lidar_rpy_deg = sim_config.rig.lidar_rpy_deg;
  config.max_range_m = sim::lidar_spec(lidar).max_range_m;
  LidarInertialOdometry odometry(config);

  Run run;
  run.world = world_kind;
  run.lidar = lidar;
  run.session = session;
  run.use_imu = use_imu;
  run.world_seed = world_seed;
  run.irregular = irregular;
  run.drop_seed = drop_seed;
  run.misconfig = misconfig;
  if (misconfig == "beams") {
    char unit[96];
    std::snprintf(unit, sizeof(unit), "beams %g m %g deg %g deg", beam_errors.x(), beam_errors.y(),
                  beam_errors.z());
    run.misconfig = unit;
  }
  SweepDropper dropper(irregular, seed + 7 + static_cast<uint64_t>(drop_seed));
  std::vector<StampedPose> estimate;
  std::vector<double> cycle_ms;
  std::array<std::vector<double>, 5> stage_ms;
  const int64_t total_sweeps = simulator.num_sweeps();
  const auto consume = [&](const std::vector<OdometryEstimate>& out) {
    for (const OdometryEstimate& e : out) {
      estimate.push_back({e.utime_us * 1e-6, e.T_odom_body});
      if (!e.ring_adaptation.empty()) {
        run.ring_adaptation = e.ring_adaptation;
      }
      if (e.extrinsic_check) {
        run.extrinsic_check = e.extrinsic_check->message;
        run.extrinsic_check_at_s = (e.utime_us - recipe.start_utime) * 1e-6;
        run.extrinsic_warned = e.extrinsic_check->warn;
      }
      if (trace > 0 && estimate.size() % trace == 0) {
        const double t = e.utime_us * 1e-6 - recipe.start_utime * 1e-6;
        const Eigen::Isometry3d gt = trajectory.pose(t);
        const Eigen::Isometry3d gt0 =
            trajectory.pose(estimate.front().time_s - recipe.start_utime * 1e-6);
        const Eigen::Isometry3d rel_gt = gt0.inverse() * gt;
        const Eigen::Vector3d rpy_est = so3::to_rpy(e.T_odom_body.linear()) * so3::kRadToDeg;
        const Eigen::Vector3d rpy_gt = so3::to_rpy(rel_gt.linear()) * so3::kRadToDeg;
        std::fprintf(stderr,
                     "t %6.1f est %9.4f %9.4f %7.4f gt %9.4f %9.4f %7.4f rpy est %7.3f %7.3f %8.3f "
                     "gt %7.3f %7.3f %8.3f fit %.3f corr %5d deg %d v %.2f ba %.3f %.3f %.3f bg "
                     "%.4f %.4f %.4f ms %.1f%s%s%s%s\n",
                     t, e.T_odom_body.translation().x(), e.T_odom_body.translation().y(),
                     e.T_odom_body.translation().z(), rel_gt.translation().x(),
                     rel_gt.translation().y(), rel_gt.translation().z(), rpy_est.x(), rpy_est.y(),
                     rpy_est.z(), rpy_gt.x(), rpy_gt.y(), rpy_gt.z(), e.fitness_m,
                     e.correspondences, e.degenerate ? 1 : 0, e.velocity_odom.norm(),
                     e.accel_bias.x(), e.accel_bias.y(), e.accel_bias.z(), e.gyro_bias.x(),
                     e.gyro_bias.y(), e.gyro_bias.z(), e.timings.total_ms,
                     e.lost_reason.empty() ? "" : " lost: ", e.lost_reason.c_str(),
                     e.reanchored.empty() ? "" : " found again: ", e.reanchored.c_str());
      }
      cycle_ms.push_back(e.timings.total_ms);
      const double stages[5] = {e.timings.preprocess_ms, e.timings.propagate_ms,
                                e.timings.register_ms, e.timings.map_ms, e.timings.keyframe_ms};
      for (int k = 0; k < 5; ++k) {
        stage_ms[k].push_back(stages[k]);
      }
      if (static_cast<int64_t>(cycle_ms.size()) == total_sweeps / 4) {
        run.rss_quarter_mb = read_process_memory().rss_mb;
      }
    }
  };
  simulator.run(
      [&](ImuSample s) {
        imu_fault.apply(s, recipe.start_utime);
        odometry.add_imu(s);
      },
      [&](const LidarScan& scan) {
        if (dropper.keep(scan.utime_us)) {
          ++run.sweeps_used;
          odometry.add_scan(scan);
          consume(odometry.process());
        }
      },
      [](double) {}, 2);
  consume(odometry.flush());
  run.rss_end_mb = read_process_memory().rss_mb;
  run.peak_rss_mb = read_process_memory().peak_mb;
  run.longest_gap_s = dropper.longest_gap_s();
  run.map_points = odometry.map_points();
  run.counters = odometry.counters();
  run.imu_fault = imu_fault.describe();
  if (use_imu) {
    // The true biases drift only a little (random walk) from their turn-on values.
    run.accel_bias_error = (odometry.state().ba - simulator.initial_accel_bias()).norm();
    run.gyro_bias_error = (odometry.state().bg - simulator.initial_gyro_bias()).norm();
  }
  eval::EvalConfig eval_config;
  eval_config.alignment = eval::AlignmentMode::kSe3;
  run.metrics =
      eval::evaluate_trajectory(simulator.ground_truth(100.0), Trajectory(estimate), eval_config);
  run.latency = eval::compute_latency_stats(cycle_ms);
  for (int k = 0; k < 5; ++k) {
    run.stage_median_ms[k] = eval::compute_latency_stats(stage_ms[k]).median_ms;
  }
  return run;
}

void print_row(const Run& r) {
  std::printf(
      "| %s | %lld | %s | %s | %s | %s%s | %.1f | %.0f | %.3f | %.3f | %.3f | %.1f | %.1f | %.1f | "
      "%.0f | %.0f | %.0f | %zu | %lld | %lld (%lld) | %lld (%lld, %lld) | %.4f | %.5f | "
      "%.1f/%.1f/%.1f/%.1f/%.1f |\n",
      r.world.c_str(), static_cast<long long>(r.world_seed), r.lidar.c_str(), r.session.c_str(),
      r.use_imu ? "yes" : "no", r.irregular ? "irregular" : "all",
      r.irregular && r.drop_seed != 0 ? (" #" + std::to_string(r.drop_seed)).c_str() : "",
      r.longest_gap_s, r.metrics.path_length_m, r.metrics.ate_position_rmse_m,
      r.metrics.rpe_translation_percent, r.metrics.rpe_rotation_deg_per_100m, r.latency.median_ms,
      r.latency.p99_ms, r.latency.max_ms, r.rss_quarter_mb, r.rss_end_mb, r.peak_rss_mb,
      r.map_points, static_cast<long long>(r.counters.degenerate_scans),
      static_cast<long long>(r.counters.searched_scans),
      static_cast<long long>(r.counters.second_guesses),
      static_cast<long long>(r.counters.lost_scans),
      static_cast<long long>(r.counters.map_restarts), static_cast<long long>(r.counters.reanchors),
      r.accel_bias_error, r.gyro_bias_error, r.stage_median_ms[0], r.stage_median_ms[1],
      r.stage_median_ms[2], r.stage_median_ms[3], r.stage_median_ms[4]);
  std::fflush(stdout);
  std::fprintf(stderr, "%s %s %s rig %s: extrinsic check at %.1f s: %s\n", r.world.c_str(),
               r.lidar.c_str(), r.session.c_str(), r.misconfig.c_str(), r.extrinsic_check_at_s,
               r.extrinsic_check.empty() ? "(none)" : r.extrinsic_check.c_str());
  std::fprintf(stderr,
               "%s %s %s IMU fault %s: %lld health resets, %lld sweeps contradicting the IMU\n",
               r.world.c_str(), r.lidar.c_str(), r.session.c_str(), r.imu_fault.c_str(),
               static_cast<long long>(r.counters.health_resets),
               static_cast<long long>(r.counters.imu_disagreements));
  std::fprintf(
      stderr,
      "%s %s %s: %lld sweeps fitting worse deskewed again, %lld fitting far worse "
      "searched again, %lld moved, %lld after a pause along their own twist, %lld placed in "
      "a young local map\n",
      r.world.c_str(), r.lidar.c_str(), r.session.c_str(),
      static_cast<long long>(r.counters.poor_fits_deskewed),
      static_cast<long long>(r.counters.poor_fits_searched),
      static_cast<long long>(r.counters.poor_fits_moved),
      static_cast<long long>(r.counters.own_twists_after_gaps),
      static_cast<long long>(r.counters.young_map_searches_accepted));
}
}  // namespace

int main(int argc, char** argv) {
  std::string worlds = "campus,corridor";
  std::string lidars = "all";
  std::string sessions = "A";
  std::string json_path = "bench/results/odometry.json";
  double length_scale = 1.0;
  std::string imu = "on";
  std::string timing = "regular";
  std::string misconfig = "none";
  std::string beam_errors = "0.02,0.1,0.1";
  std::string imu_fault = "none";
  int trace = 0;
  bool clean_imu = false;
  int world_seed = 1;
  std::string drop_seeds = "0";
  std::string config_path;
  CommandLine cli("bench_odometry", "LiDAR-inertial odometry on simulated sessions.");
  cli.add_option("worlds", &worlds, "campus, corridor or campus,corridor");
  cli.add_option("lidar", &lidars, "comma list of models, or all");
  cli.add_option("sessions", &sessions, "campus sessions (the corridor runs A)");
  cli.add_option("length-scale", &length_scale, "scale the sessions' route lengths");
  cli.add_option("json", &json_path, "result file ('' for none)");
  cli.add_option("imu", &imu, "on, off (LiDAR-only: constant-velocity model) or on,off");
  cli.add_option("config", &config_path, "YAML with an 'odometry' section (tuning)");
  cli.add_flag("clean-imu", &clean_imu, "simulate a noise- and bias-free IMU (diagnosis)");
  cli.add_option("world-seed", &world_seed, "the simulated world's seed (another town)");
  cli.add_option("timing", &timing,
                 "regular, irregular (a third of the sweeps dropped at random and 1-5 s "
                 "every ~20 s) or regular,irregular");
  cli.add_option("drop-seeds", &drop_seeds,
                 "irregular timing: comma list of the drop patterns' seeds (0: the default "
                 "pattern); one run per pattern, since one pattern's ATE can hinge on a few "
                 "sweeps");
  cli.add_option("misconfig", &misconfig,
                 "none, extrinsic (LiDAR simulated yawed 90 deg on the IMU, configured as "
                 "not), clock (LiDAR clock 20 ms late, not configured) or beams (a "
                 "miscalibrated unit, --beam-errors); comma list");
  cli.add_option("beam-errors", &beam_errors,
                 "--misconfig beams: the unit's per-beam errors, 1 sigma: range bias (m), "
                 "elevation (deg), azimuth (deg)");
  cli.add_option("imu-fault", &imu_fault,
                 "none, or accel|gyro,magnitude,start_s,duration_s: the accelerometer's x "
                 "(m/s^2) or the gyro's z (rad/s) offset for a while");
  cli.add_option("trace", &trace, "print every N-th estimate against ground truth (0: none)");
  return run_program(cli, "bench_odometry", argc, argv, [&]() -> int {
    const std::vector<std::string> models =
        lidars == "all" ? sim::lidar_models() : split_list(lidars);
    for (const std::string& mode : split_list(imu + "," + timing + "," + misconfig)) {
      if (mode != "on" && mode != "off" && mode != "regular" && mode != "irregular" &&
          mode != "none" && mode != "extrinsic" && mode != "clock" && mode != "beams") {
        throw std::invalid_argument(
            "--imu takes on/off, --timing regular/irregular, --misconfig "
            "none/extrinsic/clock/beams: " +
            mode);
      }
    }
    const ImuFault fault = parse_imu_fault(imu_fault);
    const std::vector<std::string> beam_error_parts = split_list(beam_errors);
    if (beam_error_parts.size() != 3) {
      throw std::invalid_argument("--beam-errors takes range_m,elevation_deg,azimuth_deg: " +
                                  beam_errors);
    }
    const Eigen::Vector3d beam_sigmas(std::stod(beam_error_parts[0]),
                                      std::stod(beam_error_parts[1]),
                                      std::stod(beam_error_parts[2]));
    std::vector<int> drop_seed_list;
    for (const std::string& text : split_list(drop_seeds)) {
      char* end = nullptr;
      const long value = std::strtol(text.c_str(), &end, 10);
      if (text.empty() || *end != '\0' || value < 0 || value > 1000000) {
        throw std::invalid_argument("--drop-seeds takes non-negative integers: " + text);
      }
      drop_seed_list.push_back(static_cast<int>(value));
    }
    std::vector<Run> runs;
    std::printf(
        "| world | seed | lidar | session | imu | sweeps | gap max (s) | length (m) | ATE (m) | "
        "RPE (%%) | RPE (deg/100m) | "
        "ms median | ms p99 | ms max | RSS 1/4 (MB) | RSS end (MB) | peak RSS (MB) | "
        "map pts | degen | searched (second guess) | lost (restarts, found again) | "
        "ba error (m/s^2) | bg error (rad/s) | stages ms (pre/prop/reg/map/kf) |\n");
    std::printf(
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|-"
        "--|---|"
        "\n");
    for (const std::string& world : split_list(worlds)) {
      for (const std::string& session :
           world == "campus" ? split_list(sessions) : std::vector<std::string>{"A"}) {
        for (const std::string& model : models) {
          for (const std::string& imu_mode : split_list(imu)) {
            for (const std::string& timing_mode : split_list(timing)) {
              const bool irregular = timing_mode == "irregular";
              for (const int drop_seed : irregular ? drop_seed_list : std::vector<int>{0}) {
                for (const std::string& rig_mode : split_list(misconfig)) {
                  runs.push_back(run_session(world, model, session, imu_mode == "on", length_scale,
                                             trace, clean_imu, config_path, world_seed, irregular,
                                             drop_seed, rig_mode, beam_sigmas, fault));
                  print_row(runs.back());
                }
              }
            }
          }
        }
      }
    }
    if (json_path.empty()) {
      return 0;
    }
    eval::JsonWriter json;
    json.begin_object().key("benchmark").string("odometry").key("runs").begin_array();
    for (const Run& r : runs) {
      json.begin_object()
          .key("session")
          .string(r.session)
          .key("world")
          .string(r.world)
          .key("lidar")
          .string(r.lidar)
          .key("imu")
          .boolean(r.use_imu)
          .key("world_seed")
          .integer(r.world_seed)
          .key("sweeps")
          .string(r.irregular ? "irregular" : "all")
          .key("drop_seed")
          .integer(r.drop_seed)
          .key("misconfig")
          .string(r.misconfig)
          .key("extrinsic_check")
          .string(r.extrinsic_check)
          .key("extrinsic_check_at_s")
          .number(r.extrinsic_check_at_s)
          .key("extrinsic_warned")
          .boolean(r.extrinsic_warned)
          .key("ring_adaptation")
          .string(r.ring_adaptation)
          .key("sweeps_used")
          .integer(r.sweeps_used)
          .key("longest_gap_s")
          .number(r.longest_gap_s)
          .key("length_m")
          .number(r.metrics.path_length_m)
          .key("rpe_percent")
          .number(r.metrics.rpe_translation_percent)
          .key("rpe_deg_per_100m")
          .number(r.metrics.rpe_rotation_deg_per_100m)
          .key("ate_m")
          .number(r.metrics.ate_position_rmse_m)
          .key("ms_median")
          .number(r.latency.median_ms)
          .key("ms_p99")
          .number(r.latency.p99_ms)
          .key("ms_max")
          .number(r.latency.max_ms)
          .key("peak_rss_mb")
          .number(r.peak_rss_mb)
          .key("rss_quarter_mb")
          .number(r.rss_quarter_mb)
          .key("rss_end_mb")
          .number(r.rss_end_mb)
          .key("map_points")
          .integer(static_cast<int64_t>(r.map_points))
          .key("degenerate_scans")
          .integer(r.counters.degenerate_scans)
          .key("searched_scans")
          .integer(r.counters.searched_scans)
          .key("second_guesses")
          .integer(r.counters.second_guesses)
          .key("lost_scans")
          .integer(r.counters.lost_scans)
          .key("map_restarts")
          .integer(r.counters.map_restarts)
          .key("reanchors")
          .integer(r.counters.reanchors)
          .key("health_resets")
          .integer(r.counters.health_resets)
          .key("imu_disagreements")
          .integer(r.counters.imu_disagreements)
          .key("poor_fits_searched")
          .integer(r.counters.poor_fits_searched)
          .key("poor_fits_moved")
          .integer(r.counters.poor_fits_moved)
          .key("poor_fits_deskewed")
          .integer(r.counters.poor_fits_deskewed)
          .key("own_twists_after_gaps")
          .integer(r.counters.own_twists_after_gaps)
          .key("young_map_searches_accepted")
          .integer(r.counters.young_map_searches_accepted)
          .key("imu_fault")
          .string(r.imu_fault)
          .key("accel_bias_error_mps2")
          .number(r.accel_bias_error)
          .key("gyro_bias_error_rps")
          .number(r.gyro_bias_error)
          .end_object();
    }
    json.end_array().end_object();
    storage::write_file_creating_directories(json_path, json.str());
    return 0;
  });
}
