// bench_init: pose initialization over many start poses, in the form of the paper's Table I.
//
// For each case (a session of a LiDAR, against the map of session A built with the same
// LiDAR or, for cross-sensor rows, another): the odometry runs over the session's log as
// the process would, and `trials` of its keyframes, spread along the session, are the start
// poses. Each is initialized coarse-to-fine from a coarse pose drawn within 5 m and 30
// degrees of the truth, and globally without one (from that keyframe, or the next ones
// voting, up to `max_keyframes`). Errors are against the truth in the map's frame, taken
// locally: the map keyframe nearest the start pose, moved by the true relative pose, so that
// the map's own drift (its ATE) is not charged to initialization. Start poses farther than
// 10 m from every map keyframe (session B's excursion) are outside the map: the right
// answer there is "not localized"; they count only in outside_accepted.
//
//   bench_init --data DIR/campus --maps DIR/map_%s [--lidars all] [--sessions B,C,D]

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "app/program.hpp"
#include "config/yaml_config.hpp"
#include "dataset/tum_trajectory.hpp"
#include "eval/json_writer.hpp"
#include "eval/latency_stats.hpp"
#include "initializer/map_directory.hpp"
#include "initializer/pose_initializer.hpp"
#include "map/kd_tree.hpp"
#include "math/so3.hpp"
#include "odometry_node/log_drive.hpp"
#include "sim/lidar_model.hpp"
#include "sim/simulation_config.hpp"
#include "system/system_config.hpp"

namespace {
using namespace liloc;

constexpr double kPi = 3.141592653589793;
constexpr double kDeg = kPi / 180.0;
// Success: within these of the truth. Accepted beyond them: a wrong pose.
constexpr double kSuccessM = 0.5;
constexpr double kSuccessDeg = 2.0;
constexpr double kInsideMapM = 10.0;

struct Trial {
  bool inside = false;
  bool localized = false;
  double err_m = 0.0, err_deg = 0.0;
  double seconds = 0.0;  // of the search that answered (global: of each search, summed)
  int keyframes = 1;     // global: keyframes used until it answered
  bool success() const { return localized && err_m <= kSuccessM && err_deg <= kSuccessDeg; }
};

struct Row {
  std::string mode, session, lidar, map_lidar;
  int trials = 0;  // inside the map
  int outside = 0;
  int outside_accepted = 0;
  double success_rate = 0, wrong_accepted_rate = 0;
  double err_m_median = 0, err_deg_median = 0, s_median = 0, s_p95 = 0;
  double keyframes_mean = 0;
};

Row summarize(const std::string& mode, const std::string& session, const std::string& lidar,
              const std::string& map_lidar, const std::vector<Trial>& trials) {
  Row row{mode, session, lidar, map_lidar};
  std::vector<double> err_m, err_deg, seconds, keyframes;
  int success = 0, wrong = 0;
  for (const Trial& t : trials) {
    if (!t.inside) {
      ++row.outside;
      row.outside_accepted += t.localized;
      continue;
    }
    ++row.trials;
    seconds.push_back(t.seconds);
    keyframes.push_back(t.keyframes);
    if (t.success()) {
      ++success;
      err_m.push_back(t.err_m);
      err_deg.push_back(t.err_deg);
    } else if (t.localized) {
      ++wrong;
    }
  }
  if (row.trials > 0) {
    row.success_rate = static_cast<double>(success) / row.trials;
    row.wrong_accepted_rate = static_cast<double>(wrong) / row.trials;
  }
  row.err_m_median = eval::quantile(err_m, 0.5);
  row.err_deg_median = eval::quantile(err_deg, 0.5);
  row.s_median = eval::quantile(seconds, 0.5);
  row.s_p95 = eval::quantile(seconds, 0.95);
  double sum = 0.0;
  for (const double k : keyframes) {
    sum += k;
  }
  row.keyframes_mean = keyframes.empty() ? 0.0 : sum / keyframes.size();
  return row;
}

// The map: index, points, and the truth of its keyframes (session A's ground truth).
struct Map : OpenedMap {
  std::vector<Eigen::Isometry3d> T_world_keyframe;  // by position in data.keyframes
  KdTree tree;                                      // keyframes' true positions

  Map(const std::string& dir, const Trajectory& truth_a, const PolarDescriptorConfig& descriptor)
      : OpenedMap(dir, descriptor, 0.3) {
    std::vector<KdTree::Item> items;
    for (size_t i = 0; i < data.keyframes.size(); ++i) {
      const std::optional<Eigen::Isometry3d> T = truth_a.at(data.keyframes[i].utime_us * 1e-6, 0.1);
      if (!T) {
        throw std::runtime_error(dir + ": keyframe " + std::to_string(data.keyframes[i].id) +
                                 " has no ground truth in session A's");
      }
      T_world_keyframe.push_back(*T);
      items.push_back({static_cast<int64_t>(i), T->translation()});
    }
    tree = KdTree(std::move(items));
  }

  // The start pose's truth in the map frame, taken locally; nullopt outside the map.
  std::optional<Eigen::Isometry3d> truth_in_map(const Eigen::Isometry3d& T_world_query) const {
    const std::vector<KdTree::Hit> nearest = tree.nearest(T_world_query.translation(), 1);
    if (nearest.empty() || nearest.front().distance > kInsideMapM) {
      return std::nullopt;
    }
    const size_t k = static_cast<size_t>(nearest.front().id);
    return data.keyframes[k].T_map_body * T_world_keyframe[k].inverse() * T_world_query;
  }
};

struct Options {
  std::string data = "/tmp/full/sim/campus";
  std::string maps = "/tmp/full/map_%s";
  std::string lidars = "all";
  std::string sessions = "B,C,D";
  std::string cross = "hdl32:vlp16,hdl32:os1_64";
  int trials = 100;
  int max_keyframes = 3;
  bool verbose = false;    // print each start pose that fails
  bool calibrate = false;  // print every verified candidate, right or wrong
  std::string config = "config/liloc.yaml";
};

std::string map_dir(const Options& o, const std::string& lidar) {
  char text[512];
  std::snprintf(text, sizeof(text), o.maps.c_str(), lidar.c_str());
  return text;
}

std::vector<Row> run_case(const Options& options, const Map& map, const std::string& lidar,
                          const std::string& map_lidar, const std::string& session,
                          const InitializerConfig& search,
                          const PolarDescriptorConfig& descriptor) {
  const std::string dir = options.data + "/" + lidar + "/" + session;
  const Trajectory truth = read_tum(dir + "/ground_truth.tum");
  // The odometry, as the process runs it, over the session: its keyframes.
  OdometryNodeConfig odometry;
  const sim::SimulationConfig sim_config;
  odometry.odometry.lidar_translation_m = sim_config.rig.lidar_translation_m;
  odometry.odometry.lidar_rpy_deg = sim_config.rig.lidar_rpy_deg;
  odometry.odometry.max_range_m = sim::lidar_spec(lidar).max_range_m;
  std::vector<Keyframe> keyframes;
  run_odometry_on_log(dir + "/session.lcmlog", "robot0", odometry, transport::TransportConfig{},
                      [&](const Keyframe& kf) { keyframes.push_back(kf); });
  if (keyframes.size() < 10) {
    throw std::runtime_error(dir + ": the odometry gave " + std::to_string(keyframes.size()) +
                             " keyframes");
  }
  const PoseInitializer initializer(search, descriptor);
  std::mt19937 rng(static_cast<uint32_t>(std::hash<std::string>{}(session + lidar)));
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Trial> coarse_trials, global_trials;
  const size_t first = 5, last = keyframes.size() - static_cast<size_t>(options.max_keyframes) - 1;
  for (int t = 0; t < options.trials; ++t) {
    if (shutdown_requested()) {
      throw std::runtime_error("interrupted");
    }
    const size_t i = first + (last - first) * static_cast<size_t>(t) / options.trials;
    const auto query_of = [&](size_t k) {
      InitQuery q;
      q.keyframe_id = keyframes[k].id;
      q.utime_us = keyframes[k].utime_us;
      q.T_odom_body = keyframes[k].T_odom_body;
      q.cloud_body = keyframes[k].cloud_body;
      return q;
    };
    const auto truth_of = [&](size_t k) -> std::optional<Eigen::Isometry3d> {
      const std::optional<Eigen::Isometry3d> T = truth.at(keyframes[k].utime_us * 1e-6, 0.1);
      return T ? map.truth_in_map(*T) : std::nullopt;
    };
    const auto score = [](Trial& trial, const InitResult& r, const Eigen::Isometry3d& expected) {
      trial.localized = r.localized();
      if (r.best) {
        const Eigen::Isometry3d error = expected.inverse() * r.best->T_map_body;
        trial.err_m = error.translation().norm();
        trial.err_deg = se3::rotation_angle(error) / kDeg;
      }
    };
    // --calibrate: every verified candidate, right or wrong, for choosing the acceptance.
    const auto calibrate = [&](const char* mode, const InitResult& r,
                               const std::optional<Eigen::Isometry3d>& truth_pose) {
      if (!options.calibrate || !truth_pose) {
        return;
      }
      for (const InitCandidate& c : r.candidates) {
        if (c.verified) {
          const Eigen::Isometry3d e = truth_pose->inverse() * c.T_map_body;
          std::printf(
              "candidate %s %s %s %d fitness %.4f overlap %.3f inliers %.3f descriptor "
              "%.3f degenerate %d error_m %.3f error_deg %.2f\n",
              mode, session.c_str(), lidar.c_str(), c.rejected.empty() ? 1 : 0, c.fitness_m,
              c.overlap, c.inlier_ratio, c.descriptor_distance, c.degenerate ? 1 : 0,
              e.translation().norm(), se3::rotation_angle(e) / kDeg);
        }
      }
    };
    const std::optional<Eigen::Isometry3d> expected = truth_of(i);
    // Fresh targets per trial: each start pays for building its registration targets.
    Trial coarse_trial;
    coarse_trial.inside = expected.has_value();
    if (expected) {
      const SubmapTargets targets(map.points);
      CoarsePose coarse;
      const double r = 5.0 * std::sqrt(0.5 * (u(rng) + 1.0)), a = kPi * u(rng);
      coarse.x_m = expected->translation().x() + r * std::cos(a);
      coarse.y_m = expected->translation().y() + r * std::sin(a);
      coarse.yaw_rad = so3::yaw(expected->linear()) + 30.0 * kDeg * u(rng);
      coarse.sigma_xy_m = 5.0;
      coarse.sigma_yaw_rad = 30.0 * kDeg;
      const InitResult r_coarse =
          initializer.coarse_to_fine(map.index, query_of(i), coarse, targets);
      score(coarse_trial, r_coarse, *expected);
      calibrate("coarse", r_coarse, expected);
      if (options.calibrate) {
        // From the truth itself: is the registration's minimum where the truth is?
        calibrate("oracle", initializer.refine(map.index, query_of(i), *expected, targets),
                  expected);
      }
      coarse_trial.seconds = r_coarse.time_ms / 1000.0;
      if (options.calibrate) {
        std::printf("time coarse %.1f ms: targets %.1f ms, registration %.1f ms\n",
                    r_coarse.time_ms, r_coarse.targets_ms, r_coarse.registration_ms);
      }
      if (options.verbose && !coarse_trial.success()) {
        std::printf("coarse %s %s keyframe %zu at (%.1f, %.1f): %s (error %.2f m %.2f deg)\n",
                    session.c_str(), lidar.c_str(), i, expected->translation().x(),
                    expected->translation().y(), r_coarse.reason.c_str(), coarse_trial.err_m,
                    coarse_trial.err_deg);
      }
    }
    coarse_trials.push_back(coarse_trial);
    // Global: this keyframe, then the next ones voting (as the node does).
    Trial global_trial;
    global_trial.inside = expected.has_value();
    HypothesisVoter voter(HypothesisVoter::Config{});
    for (int k = 0; k < options.max_keyframes; ++k) {
      const size_t j = i + static_cast<size_t>(k);
      const SubmapTargets targets(map.points);
      const InitQuery q = query_of(j);
      const InitResult r = initializer.global(map.index, q, targets);
      global_trial.seconds += r.time_ms / 1000.0;
      calibrate("global", r, truth_of(j));
      global_trial.keyframes = k + 1;
      const std::optional<Eigen::Isometry3d> expected_j = truth_of(j);
      std::optional<Eigen::Isometry3d> answer;
      if (r.localized()) {
        answer = r.best->T_map_body;
      } else if (const auto T_map_odom = voter.add(q, r.candidates)) {
        answer = *T_map_odom * q.T_odom_body;
      }
      if (options.verbose && !answer) {
        std::printf("global %s %s keyframe %zu (%d): %s\n", session.c_str(), lidar.c_str(), j, k,
                    r.reason.c_str());
      }
      if (answer) {
        global_trial.localized = true;
        if (expected_j) {
          const Eigen::Isometry3d error = expected_j->inverse() * *answer;
          global_trial.err_m = error.translation().norm();
          global_trial.err_deg = se3::rotation_angle(error) / kDeg;
        } else {
          global_trial.err_m = 1e9;  // accepted where the map is not
        }
        break;
      }
    }
    global_trials.push_back(global_trial);
  }
  return {summarize("coarse", session, lidar, map_lidar, coarse_trials),
          summarize("global", session, lidar, map_lidar, global_trials)};
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  std::string json_path = "bench/results/init.json";
  CommandLine cli("bench_init", "Pose initialization over many start poses (paper Table I form).");
  cli.add_option("data", &options.data, "simulated campus sessions: <data>/<lidar>/<session>/");
  cli.add_option("maps", &options.maps, "map directory of session A per LiDAR (%s: the LiDAR)");
  cli.add_option("lidars", &options.lidars, "comma list, or all");
  cli.add_option("sessions", &options.sessions, "comma list of B, C, D");
  cli.add_option("cross", &options.cross, "map_lidar:lidar pairs, comma separated ('' none)");
  cli.add_option("trials", &options.trials, "start poses per case");
  cli.add_option("max-keyframes", &options.max_keyframes, "global: keyframes voting at most");
  cli.add_option("config", &options.config, "system config (the initializer's search)");
  cli.add_flag("verbose", &options.verbose, "print each start pose that fails, and why");
  cli.add_flag("calibrate", &options.calibrate,
               "print every verified candidate of the global search with its error");
  cli.add_option("json", &json_path, "result file ('' for none)");
  return run_program(cli, "bench_init", argc, argv, [&]() -> int {
    const SystemConfig config = load_config<SystemConfig>(options.config);
    const std::vector<std::string> lidars =
        options.lidars == "all" ? sim::lidar_models() : split_list(options.lidars);
    std::vector<std::pair<std::string, std::string>> cases;  // (map lidar, session lidar)
    for (const std::string& l : lidars) {
      cases.emplace_back(l, l);
    }
    for (const std::string& pair : split_list(options.cross)) {
      const size_t colon = pair.find(':');
      cases.emplace_back(pair.substr(0, colon), pair.substr(colon + 1));
    }
    std::vector<Row> rows;
    std::map<std::string, std::unique_ptr<Map>> maps;
    for (const auto& [map_lidar, lidar] : cases) {
      std::unique_ptr<Map>& map = maps[map_lidar];
      if (!map) {
        map = std::make_unique<Map>(
            map_dir(options, map_lidar),
            read_tum(options.data + "/" + map_lidar + "/A/ground_truth.tum"), config.descriptor);
      }
      for (const std::string& session : split_list(options.sessions)) {
        spdlog::info("{} session {} against the {} map", lidar, session, map_lidar);
        for (const Row& r : run_case(options, *map, lidar, map_lidar, session,
                                     config.initializer.search, config.descriptor)) {
          rows.push_back(r);
          spdlog::info("  {}: success {:.1f} %, wrong {:.1f} %, {:.3f} m, {:.2f} deg, {:.2f} s",
                       r.mode, 100 * r.success_rate, 100 * r.wrong_accepted_rate, r.err_m_median,
                       r.err_deg_median, r.s_median);
        }
      }
    }
    std::printf(
        "| mode | session | lidar | map | trials | success (%%) | wrong accepted (%%) | xyz (m) | "
        "rpy (rad) | time median (s) | p95 (s) | keyframes | outside: accepted |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (const Row& r : rows) {
      std::printf(
          "| %s | %s | %s | %s | %d | %.1f | %.1f | %.3f | %.4f | %.2f | %.2f | %.1f | %d / %d |\n",
          r.mode.c_str(), r.session.c_str(), r.lidar.c_str(), r.map_lidar.c_str(), r.trials,
          100 * r.success_rate, 100 * r.wrong_accepted_rate, r.err_m_median,
          r.err_deg_median * kDeg, r.s_median, r.s_p95, r.keyframes_mean, r.outside_accepted,
          r.outside);
    }
    if (!json_path.empty()) {
      eval::JsonWriter json;
      json.begin_object().key("benchmark").string("init").key("rows").begin_array();
      for (const Row& r : rows) {
        json.begin_object()
            .key("mode")
            .string(r.mode)
            .key("session")
            .string(r.session)
            .key("lidar")
            .string(r.lidar)
            .key("map_lidar")
            .string(r.map_lidar)
            .key("trials")
            .integer(r.trials)
            .key("success_rate")
            .number(r.success_rate)
            .key("wrong_accepted_rate")
            .number(r.wrong_accepted_rate)
            .key("err_m_median")
            .number(r.err_m_median)
            .key("err_deg_median")
            .number(r.err_deg_median)
            .key("s_median")
            .number(r.s_median)
            .key("s_p95")
            .number(r.s_p95)
            .key("keyframes_mean")
            .number(r.keyframes_mean)
            .key("outside_trials")
            .integer(r.outside)
            .key("outside_accepted")
            .integer(r.outside_accepted)
            .end_object();
      }
      json.end_array().end_object();
      std::ofstream(json_path) << json.str() << "\n";
    }
    return 0;
  });
}
