// bench_efg: the joint optimizer (egocentric factor graph) on simulated sessions against the
// map of session A, in the form of the paper's Tables II and III, with the ablations.
//
// For each case (a LiDAR, a world and a session): the odometry runs over the session's log as the
// process would; the first keyframe is initialized (coarse-to-fine from a coarse pose 3 m
// and 20 degrees off the truth, or globally for session D, keyframe after keyframe until
// it localizes); then every keyframe goes through the localizer (mode by Eq. 11's overlap,
// scan match, JFGO). Errors are in the map frame: the truth is carried into it by the
// rigid transform that fits the map's keyframes to session A's truth, so the map's own
// error counts.
//
// The modes are compared with the truth's own: where the truth's Eq. 11 overlap with the
// map says RLM, and, along the path, how far each of the truth's switches (leaving or
// re-entering the mapped area) is from the estimate's nearest switch the same way.
//
// The corridor's second session (C) measures the degenerate case: a tunnel whose scans fix
// its axis only at lights, cabinets and corners.
//
//   bench_efg --data DIR --maps 'DIR/maps/{world}/{lidar}' [--lidars hdl32]
//             [--sessions B,C,D,corridor:C] [--variants full,direct,...] [--plots DIR]

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "app/program.hpp"
#include "config/yaml_config.hpp"
#include "dataset/tum_trajectory.hpp"
#include "eval/json_writer.hpp"
#include "eval/latency_stats.hpp"
#include "eval/trajectory_metrics.hpp"
#include "eval/trajectory_plot.hpp"
#include "initializer/map_directory.hpp"
#include "initializer/pose_initializer.hpp"
#include "math/so3.hpp"
#include "odometry_node/log_drive.hpp"
#include "optimizer/localizer.hpp"
#include "sim/lidar_model.hpp"
#include "sim/simulation_config.hpp"
#include "system/system_config.hpp"

namespace {
using namespace liloc;

constexpr double kPi = 3.141592653589793;
constexpr double kFailedM = 2.0;  // a pose this far from the truth: the run failed

struct Row {
  std::string world, session, lidar, variant;
  double ate_m = 0, xyz_rpy = 0, rot_deg = 0;
  bool failed = false;
  double rlm_share = 0, rlm_share_truth = 0;
  double jfgo_ms_median = 0, latency_ms_median = 0, latency_ms_p99 = 0, max_jump_m = 0;
  int keyframes = 0;
  std::string init;  // how the session started
  // Mode switches: the truth's, the estimate's, and the truth's that the estimate did not
  // make the same way; the largest distance along the path (m) of a matched one.
  int switches_truth = 0, switches = 0, switches_missed = 0;
  double switch_error_m_max = 0;
  std::vector<StampedPose> estimate, truth;  // map frame, for the plot
  std::vector<eval::ModeSample> modes;
};

// Compares the estimate's mode switches with the truth's along the path.
void score_switches(const std::vector<double>& path_m, const std::vector<bool>& rlm,
                    const std::vector<bool>& rlm_truth, Row& row) {
  struct Switch {
    double at_m;
    bool enters;
  };
  const auto switches_of = [&](const std::vector<bool>& mode) {
    std::vector<Switch> out;
    for (size_t k = 1; k < mode.size(); ++k) {
      if (mode[k] != mode[k - 1]) {
        out.push_back({path_m[k], mode[k]});
      }
    }
    return out;
  };
  const std::vector<Switch> truth = switches_of(rlm_truth), estimate = switches_of(rlm);
  row.switches_truth = static_cast<int>(truth.size());
  row.switches = static_cast<int>(estimate.size());
  for (const Switch& t : truth) {
    double nearest = std::numeric_limits<double>::infinity();
    for (const Switch& e : estimate) {
      if (e.enters == t.enters) {
        nearest = std::min(nearest, std::abs(e.at_m - t.at_m));
      }
    }
    if (std::isfinite(nearest)) {
      row.switch_error_m_max = std::max(row.switch_error_m_max, nearest);
    } else {
      ++row.switches_missed;
    }
  }
}

// The variant's localizer config from the full method's.
LocalizerConfig variant_config(LocalizerConfig c, const std::string& variant) {
  if (variant == "direct") {
    c.graph.direct = true;
  } else if (variant == "scan_to_map_only") {
    c.scan_to_map_only = true;
  } else if (variant == "ilm_only") {
    c.ilm_only = true;
  } else if (variant == "no_mode_switch") {
    c.no_mode_switch = true;
  } else if (variant == "unweighted") {
    c.graph.unweighted = true;
  } else if (variant == "no_marginalization") {
    c.graph.no_marginalization = true;
  } else if (variant != "full") {
    throw std::invalid_argument("unknown variant '" + variant + "'");
  }
  return c;
}

struct Session {
  std::vector<Keyframe> keyframes;
  std::vector<ImuSample> imu;
  Trajectory truth;
};

std::vector<ImuSample> imu_between(const std::vector<ImuSample>& imu, int64_t from_us,
                                   int64_t to_us) {
  auto first = std::lower_bound(imu.begin(), imu.end(), from_us,
                                [](const ImuSample& s, int64_t t) { return s.utime_us < t; });
  if (first != imu.begin()) {
    --first;  // the sample at or before the start covers it
  }
  const auto last = std::upper_bound(first, imu.end(), to_us,
                                     [](int64_t t, const ImuSample& s) { return t < s.utime_us; });
  return {first, last};
}

Row run_case(const OpenedMap& map, const Eigen::Isometry3d& T_map_world, const Session& session,
             const std::string& world, const std::string& session_name, const std::string& lidar,
             const std::string& variant, const LocalizerConfig& full,
             const InitializerConfig& init_config, const PolarDescriptorConfig& descriptor) {
  Row row;
  row.world = world;
  row.session = session_name;
  row.lidar = lidar;
  row.variant = variant;
  const SubmapTargets targets(map.points, 64);
  // The node's map client keeps the submaps it fetched in memory; read from disk here, they
  // would put file reads into the timings. Every submap is read before the timed run.
  for (const Submap& submap : map.data.submaps) {
    targets.points(submap.id);
  }
  const auto truth_in_map = [&](const Keyframe& kf) -> std::optional<Eigen::Isometry3d> {
    const std::optional<Eigen::Isometry3d> T = session.truth.at(kf.utime_us * 1e-6, 0.1);
    return T ? std::optional<Eigen::Isometry3d>(T_map_world * *T) : std::nullopt;
  };
  const auto query_of = [](const Keyframe& kf) {
    InitQuery q;
    q.keyframe_id = kf.id;
    q.utime_us = kf.utime_us;
    q.T_odom_body = kf.T_odom_body;
    q.cloud_body = kf.cloud_body;
    return q;
  };
  // Initialization.
  const PoseInitializer initializer(init_config, descriptor);
  size_t first = 0;
  std::optional<InitResult> init;
  for (; first < session.keyframes.size() && !init; ++first) {
    const Keyframe& kf = session.keyframes[first];
    const std::optional<Eigen::Isometry3d> truth = truth_in_map(kf);
    InitResult r;
    if (session_name == "D") {
      r = initializer.global(map.index, query_of(kf), targets);
    } else if (truth) {
      CoarsePose coarse;
      coarse.x_m = truth->translation().x() + 2.0;
      coarse.y_m = truth->translation().y() - 2.2;
      coarse.yaw_rad = so3::yaw(truth->linear()) + 20.0 * kPi / 180.0;
      r = initializer.coarse_to_fine(map.index, query_of(kf), coarse, targets);
    }
    if (r.localized()) {
      init = r;
      break;
    }
  }
  if (!init) {
    row.failed = true;
    row.init = "never initialized";
    return row;
  }
  row.init = init->method + " at keyframe " + std::to_string(first);
  if (const std::optional<Eigen::Isometry3d> T = truth_in_map(session.keyframes[first])) {
    spdlog::debug("{} {} {}: initialized ({}) {:.3f} m from the truth: {}", world, lidar,
                  session_name, row.init,
                  (init->best->T_map_body.translation() - T->translation()).norm(), init->reason);
    for (const InitCandidate& c : init->candidates) {
      spdlog::debug(
          "  candidate {:.3f} m from the truth: fitness {:.3f} overlap {:.2f} inliers "
          "{:.2f} degenerate {} {}",
          (c.T_map_body.translation() - T->translation()).norm(), c.fitness_m, c.overlap,
          c.inlier_ratio, c.degenerate, c.rejected);
    }
  }
  Localizer localizer(variant_config(full, variant), map.index, targets);
  const auto to_localizer = [&](size_t k) {
    const Keyframe& kf = session.keyframes[k];
    LocalizerKeyframe in;
    in.id = kf.id;
    in.utime_us = kf.utime_us;
    in.T_odom_body = kf.T_odom_body;
    in.odometry_covariance = kf.covariance;
    in.cloud_body = kf.cloud_body;
    if (k > 0) {
      in.imu = imu_between(session.imu, session.keyframes[k - 1].utime_us, kf.utime_us);
    }
    return in;
  };
  localizer.start(to_localizer(first), init->best->T_map_body, init->best->covariance);
  std::vector<double> upkeep_ms{localizer.upkeep()};
  std::vector<StampedPose>& estimate = row.estimate;
  std::vector<StampedPose>& truth = row.truth;
  std::vector<double> jfgo_ms, latency_ms, path_m, scan_match_ms, target_ms, covariance_ms,
      marginalization_ms;
  std::vector<bool> rlm, rlm_truth;
  Eigen::Isometry3d previous_T_map_odom = localizer.T_map_odom();
  for (size_t k = first + 1; k < session.keyframes.size(); ++k) {
    const LocalizerOutput out = localizer.add(to_localizer(k));
    upkeep_ms.push_back(localizer.upkeep());  // after the pose is out: not in its latency
    const Keyframe& kf = session.keyframes[k];
    const std::optional<Eigen::Isometry3d> T_truth = truth_in_map(kf);
    if (!T_truth) {
      continue;
    }
    path_m.push_back(truth.empty()
                         ? 0.0
                         : path_m.back() +
                               (T_truth->translation() - truth.back().T.translation()).norm());
    estimate.push_back({kf.utime_us * 1e-6, out.T_map_body});
    truth.push_back({kf.utime_us * 1e-6, *T_truth});
    rlm.push_back(out.mode == LocalizationMode::kRelocalization);
    row.modes.push_back({kf.utime_us * 1e-6, rlm.back() ? eval::kModeRlm : eval::kModeIlm});
    // The truth's own overlap (Eq. 11) with the map: where RLM is right.
    double overlap = 0.0;
    for (const KdTree::Hit& hit : map.index.submaps().nearest_submaps(T_truth->translation(), 3)) {
      overlap = std::max(overlap, overlap_ratio(T_truth->translation(), full.overlap_half_side_m,
                                                map.index.submaps().submap(hit.id)->bounds));
    }
    rlm_truth.push_back(overlap >= full.overlap_threshold);
    spdlog::debug("keyframe {}: {} overlap {:.2f} (truth {:.2f}), error {:.3f} m, {}", k,
                  rlm.back() ? "RLM" : "ILM", out.overlap, overlap,
                  (out.T_map_body.translation() - T_truth->translation()).norm(),
                  out.scan_matched ? "scan matched, fitness " + std::to_string(out.fitness_m)
                                   : "gate: " + out.gate);
    jfgo_ms.push_back(out.graph.solve_ms);
    scan_match_ms.push_back(out.scan_match_ms);
    target_ms.push_back(out.target_ms);
    covariance_ms.push_back(out.graph.covariance_ms);
    marginalization_ms.push_back(out.graph.marginalization_ms);
    latency_ms.push_back(out.total_ms);
    const Eigen::Isometry3d T_map_odom = localizer.T_map_odom();
    // How far the new correction moves the keyframe's pose in the map frame.
    row.max_jump_m =
        std::max(row.max_jump_m, ((previous_T_map_odom * kf.T_odom_body).translation() -
                                  (T_map_odom * kf.T_odom_body).translation())
                                     .norm());
    previous_T_map_odom = T_map_odom;
    if ((out.T_map_body.translation() - T_truth->translation()).norm() > kFailedM) {
      row.failed = true;
    }
  }
  eval::EvalConfig eval_config;
  eval_config.alignment = eval::AlignmentMode::kFixed;
  const eval::TrajectoryMetrics m =
      eval::evaluate_trajectory(Trajectory(truth), Trajectory(estimate), eval_config);
  row.ate_m = m.ate_position_rmse_m;
  row.xyz_rpy = m.ate_full_rmse;
  row.rot_deg = m.rotation_rmse_deg;
  row.keyframes = static_cast<int>(estimate.size());
  const auto share = [](const std::vector<bool>& v) {
    return v.empty() ? 0.0 : static_cast<double>(std::count(v.begin(), v.end(), true)) / v.size();
  };
  row.rlm_share = share(rlm);
  row.rlm_share_truth = share(rlm_truth);
  score_switches(path_m, rlm, rlm_truth, row);
  row.jfgo_ms_median = eval::quantile(jfgo_ms, 0.5);
  // Where the latency goes.
  const auto stage = [](const std::vector<double>& ms) {
    return fmt::format("{:.1f} / {:.1f}", eval::quantile(ms, 0.5), eval::quantile(ms, 0.99));
  };
  spdlog::info(
      "{} {} {} {}: median / p99 ms: scan match {} (of it the target {}), JFGO {}, covariance {}, "
      "marginalization {}, total {}; after the pose, the target's upkeep {}",
      world, session_name, lidar, variant, stage(scan_match_ms), stage(target_ms), stage(jfgo_ms),
      stage(covariance_ms), stage(marginalization_ms), stage(latency_ms), stage(upkeep_ms));
  row.latency_ms_median = eval::quantile(latency_ms, 0.5);
  row.latency_ms_p99 = eval::quantile(latency_ms, 0.99);
  return row;
}

// "{world}" and "{lidar}" in a path pattern replaced.
std::string expand(std::string pattern, const std::string& world, const std::string& lidar) {
  for (const auto& [key, value] :
       {std::pair<std::string, std::string>{"{world}", world}, {"{lidar}", lidar}}) {
    for (size_t at = pattern.find(key); at != std::string::npos; at = pattern.find(key, at)) {
      pattern.replace(at, key.size(), value);
      at += value.size();
    }
  }
  return pattern;
}

// The map of session A, and the map frame against the world: the map's keyframes fitted
// to session A's truth.
struct PriorMap {
  explicit PriorMap(const std::string& directory, const std::string& truth_a_path,
                    const SystemConfig& config)
      : opened(directory, config.descriptor, 0.3) {
    const Trajectory truth_a = read_tum(truth_a_path);
    std::vector<Eigen::Vector3d> in_map, in_world;
    std::vector<StampedPose> keyframes;
    for (const MapKeyframe& kf : opened.data.keyframes) {
      if (const auto T = truth_a.at(kf.utime_us * 1e-6, 0.1)) {
        in_map.push_back(kf.T_map_body.translation());
        in_world.push_back(T->translation());
      }
      keyframes.push_back({kf.utime_us * 1e-6, kf.T_map_body});
    }
    T_map_world = eval::fit_rigid_alignment(in_world, in_map);
    spdlog::info("map {}: its z {:.2f} deg from the truth's up", directory,
                 so3::tilt(T_map_world.linear()) * so3::kRadToDeg);
    mapped_area = Trajectory(std::move(keyframes));
  }
  OpenedMap opened;
  Eigen::Isometry3d T_map_world = Eigen::Isometry3d::Identity();
  Trajectory mapped_area;  // the map's keyframes, for the plot
};

// Sessions as "world:S" or "S" (campus), grouped by world in order of first mention.
std::vector<std::pair<std::string, std::vector<std::string>>> sessions_by_world(
    const std::string& list) {
  std::vector<std::pair<std::string, std::vector<std::string>>> out;
  for (const std::string& item : split_list(list)) {
    const size_t colon = item.find(':');
    const std::string world = colon == std::string::npos ? "campus" : item.substr(0, colon);
    const std::string session = colon == std::string::npos ? item : item.substr(colon + 1);
    auto it = std::find_if(out.begin(), out.end(), [&](const auto& w) { return w.first == world; });
    if (it == out.end()) {
      out.push_back({world, {}});
      it = out.end() - 1;
    }
    it->second.push_back(session);
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::string data = "/tmp/full/sim", maps = "/tmp/full/maps/{world}/{lidar}", lidars = "hdl32";
  std::string sessions = "B,C,D,corridor:C";
  std::string variants =
      "full,direct,scan_to_map_only,ilm_only,no_mode_switch,unweighted,no_marginalization";
  std::string config_path = "config/liloc.yaml", json_path = "bench/results/efg.json";
  std::string plots_dir;
  CommandLine cli("bench_efg",
                  "The joint optimizer on simulated sessions (paper Tables II-III form).");
  cli.add_option("data", &data, "simulated sessions: <data>/<world>/<lidar>/<session>/");
  cli.add_option("maps", &maps,
                 "map directory of session A ({world} and {lidar} replaced in the pattern)");
  cli.add_option("lidars", &lidars, "comma list, or all");
  cli.add_option("sessions", &sessions, "comma list of S (campus) or world:S");
  cli.add_option("variants", &variants, "full and ablations, comma list");
  cli.add_option("config", &config_path, "system config");
  cli.add_option("json", &json_path, "result file ('' for none)");
  cli.add_option("plots", &plots_dir,
                 "write <dir>/efg_<world>_<lidar>_<session>_<variant>.png, the estimate "
                 "coloured by mode");
  return run_program(cli, "bench_efg", argc, argv, [&]() -> int {
    const SystemConfig config = load_config<SystemConfig>(config_path);
    const std::vector<std::string> lidar_list =
        lidars == "all" ? sim::lidar_models() : split_list(lidars);
    if (!plots_dir.empty()) {
      std::filesystem::create_directories(plots_dir);
    }
    std::vector<Row> rows;
    for (const std::string& lidar : lidar_list) {
      for (const auto& [world, world_sessions] : sessions_by_world(sessions)) {
        const std::string lidar_dir = data + "/" + world + "/" + lidar;
        const PriorMap map(expand(maps, world, lidar), lidar_dir + "/A/ground_truth.tum", config);
        for (const std::string& name : world_sessions) {
          const std::string session_dir = lidar_dir + "/" + name;
          Session session;
          session.truth = read_tum(session_dir + "/ground_truth.tum");
          OdometryNodeConfig odometry;
          const sim::SimulationConfig sim_config;
          odometry.odometry.lidar_translation_m = sim_config.rig.lidar_translation_m;
          odometry.odometry.lidar_rpy_deg = sim_config.rig.lidar_rpy_deg;
          odometry.odometry.max_range_m = sim::lidar_spec(lidar).max_range_m;
          run_odometry_on_log(
              session_dir + "/session.lcmlog", "robot0", odometry, transport::TransportConfig{},
              [&](const Keyframe& kf) { session.keyframes.push_back(kf); },
              [&](const ImuSample& s) { session.imu.push_back(s); });
          for (const std::string& variant : split_list(variants)) {
            if (shutdown_requested()) {
              throw std::runtime_error("interrupted");
            }
            Row r =
                run_case(map.opened, map.T_map_world, session, world, name, lidar, variant,
                         config.optimizer.localizer, config.initializer.search, config.descriptor);
            spdlog::info(
                "{} {} {} {}: ATE {:.3f} m, RLM {:.0f} % (truth {:.0f} %), switches {} (truth {}, "
                "{} missed, within {:.1f} m), JFGO {:.1f} ms, latency {:.1f} / {:.1f} ms{} ({})",
                world, lidar, name, variant, r.ate_m, 100 * r.rlm_share, 100 * r.rlm_share_truth,
                r.switches, r.switches_truth, r.switches_missed, r.switch_error_m_max,
                r.jfgo_ms_median, r.latency_ms_median, r.latency_ms_p99, r.failed ? ", FAILED" : "",
                r.init);
            if (!plots_dir.empty() && !r.estimate.empty()) {
              eval::TrajectoryPlotInput plot;
              plot.ground_truth = Trajectory(r.truth);
              plot.estimate = Trajectory(r.estimate);
              plot.modes = eval::ModeTimeline(r.modes);
              plot.mapped_area = map.mapped_area;
              plot.title =
                  fmt::format("{} {} {} {}: ATE {:.3f} m; estimate green in RLM, orange in ILM",
                              world, lidar, name, variant, r.ate_m);
              const std::string path =
                  plots_dir + "/efg_" + world + "_" + lidar + "_" + name + "_" + variant + ".png";
              if (!cv::imwrite(path, eval::render_trajectory_plot(plot, {}))) {
                throw std::runtime_error(path + ": cannot write the plot");
              }
            }
            r.estimate.clear();
            r.truth.clear();
            r.modes.clear();
            rows.push_back(std::move(r));
          }
        }
      }
    }
    std::printf(
        "| world | session | lidar | variant | ATE (m) | xyz_rpy | rot (deg) | failed | RLM share "
        "| RLM "
        "share of the truth | switches (truth, missed) | switch error max (m) | JFGO median "
        "(ms) | latency median / p99 (ms) | max jump (m) |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (const Row& r : rows) {
      std::printf(
          "| %s | %s | %s | %s | %.3f | %.3f | %.2f | %s | %.2f | %.2f | %d (%d, %d) | %.1f | %.1f "
          "| "
          "%.1f / %.1f | %.2f |\n",
          r.world.c_str(), r.session.c_str(), r.lidar.c_str(), r.variant.c_str(), r.ate_m,
          r.xyz_rpy, r.rot_deg, r.failed ? "yes" : "no", r.rlm_share, r.rlm_share_truth, r.switches,
          r.switches_truth, r.switches_missed, r.switch_error_m_max, r.jfgo_ms_median,
          r.latency_ms_median, r.latency_ms_p99, r.max_jump_m);
    }
    if (!json_path.empty()) {
      eval::JsonWriter json;
      json.begin_object().key("benchmark").string("efg").key("rows").begin_array();
      for (const Row& r : rows) {
        json.begin_object()
            .key("world")
            .string(r.world)
            .key("session")
            .string(r.session)
            .key("lidar")
            .string(r.lidar)
            .key("variant")
            .string(r.variant)
            .key("ate_m")
            .number(r.ate_m)
            .key("xyz_rpy")
            .number(r.xyz_rpy)
            .key("rot_deg")
            .number(r.rot_deg)
            .key("failed")
            .boolean(r.failed)
            .key("rlm_share")
            .number(r.rlm_share)
            .key("rlm_share_truth")
            .number(r.rlm_share_truth)
            .key("switches")
            .number(r.switches)
            .key("switches_truth")
            .number(r.switches_truth)
            .key("switches_missed")
            .number(r.switches_missed)
            .key("switch_error_m_max")
            .number(r.switch_error_m_max)
            .key("jfgo_ms_median")
            .number(r.jfgo_ms_median)
            .key("latency_ms_median")
            .number(r.latency_ms_median)
            .key("latency_ms_p99")
            .number(r.latency_ms_p99)
            .key("max_jump_m")
            .number(r.max_jump_m)
            .key("init")
            .string(r.init)
            .end_object();
      }
      json.end_array().end_object();
      std::ofstream(json_path) << json.str() << "\n";
    }
    return 0;
  });
}
