// liloc_eval: scores an estimated trajectory against ground truth (docs/evaluation.md).
//
//   liloc_eval GT.tum EST.tum [--align se3|first|none | --align-file T_gt_est.txt]
//   liloc_eval GT.tum RUN.lcmlog --est-channel robot0.POSE
//              [--status-channel robot0.STATUS.optimizer] [--mapped-area A_GT.tum]
//              [--out results/run_b]
//
// Prints a markdown table to stdout; --out PREFIX also writes PREFIX.md, PREFIX.json,
// PREFIX.png and PREFIX.T_gt_est.txt (the transform used, reusable with --align-file).

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "app/program.hpp"
#include "bridge/lcm_conversions.hpp"
#include "dataset/tum_trajectory.hpp"
#include "eval/eval_report.hpp"
#include "eval/mode_timeline.hpp"
#include "eval/trajectory_metrics.hpp"
#include "eval/trajectory_plot.hpp"
#include "liloc/odometry_t.hpp"
#include "liloc/status_t.hpp"
#include "math/so3.hpp"
#include "transport/log_file.hpp"

namespace {
using namespace liloc;

static_assert(eval::kModeNone == status_t::MODE_NONE &&
                  eval::kModeInitializing == status_t::MODE_INITIALIZING &&
                  eval::kModeRlm == status_t::MODE_RLM && eval::kModeIlm == status_t::MODE_ILM &&
                  eval::kModeLost == status_t::MODE_LOST,
              "eval mode constants must match status_t::MODE_*");

constexpr double kMicrosecondsToSeconds = 1e-6;

struct LoggedRun {
  Trajectory estimate;
  size_t status_messages = 0;
  eval::ModeTimeline modes;
  std::vector<double> total_ms;  // status timing "total" per cycle
  bool damaged = false;          // the log had corrupt or truncated parts
};

LoggedRun read_log(const std::string& path, const std::string& est_channel,
                   const std::string& status_channel) {
  transport::LogReader reader(path);
  transport::LogEventView event;
  std::map<int64_t, Eigen::Isometry3d> poses_by_utime;
  std::vector<eval::ModeSample> mode_samples;
  LoggedRun run;
  size_t undecodable = 0, rejected = 0, repeated = 0, bad_timings = 0;
  while (reader.next(event)) {
    if (event.channel == est_channel) {
      odometry_t msg;
      if (!transport::decode(event, msg)) {
        ++undecodable;
        continue;
      }
      try {
        // The first pose published for a time is what the robot knew then; keep it.
        if (!poses_by_utime.emplace(msg.header.utime, bridge::from_msg(msg.pose)).second) {
          ++repeated;
        }
      } catch (const std::invalid_argument&) {
        ++rejected;
      }
    } else if (!status_channel.empty() && event.channel == status_channel) {
      status_t msg;
      if (!transport::decode(event, msg)) {
        ++undecodable;
        continue;
      }
      ++run.status_messages;
      const double time_s = static_cast<double>(msg.header.utime) * kMicrosecondsToSeconds;
      mode_samples.push_back({time_s, msg.mode});
      for (int k = 0; k < msg.num_timings; ++k) {
        if (msg.timing_names[k] != "total") {
          continue;
        }
        if (std::isfinite(msg.timing_ms[k]) && msg.timing_ms[k] >= 0.0f) {
          run.total_ms.push_back(msg.timing_ms[k]);
        } else {
          ++bad_timings;
        }
      }
    }
  }
  if (reader.damage().any()) {
    run.damaged = true;
    spdlog::error("{}: damaged log: {}; the scores cover what could be read", path,
                  reader.damage().summary());
  }
  if (undecodable + rejected + bad_timings > 0) {
    spdlog::warn(
        "{}: skipped {} undecodable messages, {} non-finite poses, {} invalid 'total' "
        "timings",
        path, undecodable, rejected, bad_timings);
  }
  if (repeated > 0) {
    // Expected of the optimizer's POSE: a keyframe's sweep gets the prompt pose from its
    // ODOM and, once optimized, the keyframe's.
    spdlog::info("{}: {} pose times published again; the first of each is scored", path, repeated);
  }
  if (poses_by_utime.empty()) {
    throw std::runtime_error(path + ": no odometry_t pose on channel '" + est_channel + "'");
  }
  std::vector<StampedPose> poses;
  for (const auto& [utime, T] : poses_by_utime) {
    poses.push_back({static_cast<double>(utime) * kMicrosecondsToSeconds, T});
  }
  run.estimate = Trajectory(std::move(poses));
  run.modes = eval::ModeTimeline(std::move(mode_samples));
  return run;
}

// A 4x4 matrix, whitespace separated, row by row; the bottom row must be 0 0 0 1 and the
// rotation orthonormal (it is re-orthonormalized to remove printing round-off).
Eigen::Isometry3d read_transform_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    throw std::runtime_error("cannot open alignment file " + path);
  }
  std::vector<double> values;
  std::string token;
  while (in >> token) {
    try {
      size_t used = 0;
      values.push_back(std::stod(token, &used));
      if (used != token.size()) {
        throw std::invalid_argument(token);
      }
    } catch (const std::logic_error&) {
      throw std::runtime_error(path + ": '" + token + "' is not a number");
    }
  }
  if (values.size() != 16) {
    throw std::runtime_error(path + ": expected 16 numbers (a 4x4 matrix), found " +
                             std::to_string(values.size()));
  }
  const Eigen::Matrix4d M =
      Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(values.data());
  const Eigen::Matrix3d R = M.topLeftCorner<3, 3>();
  if (!M.allFinite() || !M.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1), 1e-9) ||
      !(R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), 1e-6)) {
    throw std::runtime_error(path + ": not a rigid transform (bottom row 0 0 0 1, orthonormal " +
                             "rotation, finite values)");
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = so3::normalize(R);
  T.translation() = M.topRightCorner<3, 1>();
  return T;
}

std::string format_transform(const Eigen::Isometry3d& T) {
  std::ostringstream s;
  s << std::setprecision(17);
  for (int row = 0; row < 4; ++row) {
    for (int col = 0; col < 4; ++col) {
      s << T.matrix()(row, col) << (col < 3 ? " " : "\n");
    }
  }
  return s.str();
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  if (!out) {
    throw std::runtime_error("cannot write " + path);
  }
}

bool is_lcm_log(const std::string& path) {
  return std::filesystem::path(path).extension() == ".lcmlog";
}
}  // namespace

int main(int argc, char** argv) {
  // stdout carries the table (for redirection); the log goes to stderr.
  spdlog::set_default_logger(spdlog::stderr_color_mt("liloc_eval"));

  std::vector<std::string> files;
  std::string est_channel;
  std::string status_channel;
  std::string align;
  std::string align_file;
  std::string mapped_area_path;
  std::string name;
  std::string out_prefix;
  eval::EvalConfig config;
  eval::TrajectoryPlotConfig plot_config;
  CommandLine cli("liloc_eval",
                  "Scores an estimated trajectory (TUM file or LCM log) against ground truth.");
  cli.add_positional("GT EST", &files,
                     "ground truth (TUM) and estimate (TUM, or .lcmlog with --est-channel)", 2);
  cli.add_option("est-channel", &est_channel, "odometry_t channel of the estimate in an .lcmlog");
  cli.add_option("status-channel", &status_channel,
                 "status_t channel in the same log: modes and 'total' cycle times");
  cli.add_option("align", &align, "se3 (the default), first or none");
  cli.add_option("align-file", &align_file,
                 "fixed T_gt_est, 4x4 matrix (subsidiary sessions: session A's transform)");
  cli.add_option("mapped-area", &mapped_area_path, "TUM path whose surroundings are mapped");
  cli.add_option("mapped-radius-m", &plot_config.mapped_area_radius_m,
                 "radius of the shaded mapped area around --mapped-area, metres");
  cli.add_option("max-gap-s", &config.max_time_gap_s,
                 "interpolate ground truth only between poses this close in time");
  cli.add_option("rpe-segment-m", &config.rpe_segment_m, "RPE segment length, metres");
  cli.add_option("name", &name, "name of the run in the table (default: EST's file name)");
  cli.add_option("out", &out_prefix, "write PREFIX.md, .json, .png and .T_gt_est.txt");

  return run_program(cli, "liloc_eval", argc, argv, [&]() -> int {
    const std::string& gt_path = files[0];
    const std::string& est_path = files[1];
    if (!align.empty() && !align_file.empty()) {
      throw std::invalid_argument("give --align or --align-file, not both");
    }
    if (!align_file.empty()) {
      config.alignment = eval::AlignmentMode::kFixed;
      config.T_gt_est_fixed = read_transform_file(align_file);
    } else if (!align.empty()) {
      config.alignment = eval::parse_alignment_mode(align);
    }

    const Trajectory ground_truth = read_tum(gt_path);
    LoggedRun run;
    if (is_lcm_log(est_path)) {
      if (est_channel.empty()) {
        throw std::invalid_argument(est_path + " is an LCM log: name its --est-channel");
      }
      run = read_log(est_path, est_channel, status_channel);
    } else {
      if (!est_channel.empty() || !status_channel.empty()) {
        throw std::invalid_argument("--est-channel and --status-channel need an .lcmlog estimate");
      }
      run.estimate = read_tum(est_path);
    }
    spdlog::info("ground truth: {} poses; estimate: {} poses", ground_truth.size(),
                 run.estimate.size());

    eval::EvalReport report;
    report.name = name.empty() ? std::filesystem::path(est_path).stem().string() : name;
    report.metrics = eval::evaluate_trajectory(ground_truth, run.estimate, config);
    if (!status_channel.empty()) {
      if (run.status_messages == 0) {
        spdlog::warn("no status_t on channel '{}': no modes, no latency", status_channel);
      } else if (run.total_ms.empty()) {
        spdlog::warn("status on '{}' has no 'total' timing: latency not reported", status_channel);
      } else {
        report.latency = eval::compute_latency_stats(run.total_ms);
      }
      report.mode_time_fractions = run.modes.time_fractions();
    }
    for (const std::string& warning : report.metrics.warnings) {
      spdlog::warn("{}", warning);
    }
    spdlog::info("{} alignment, T_gt_est:\n{}", eval::to_string(report.metrics.alignment),
                 format_transform(report.metrics.T_gt_est));

    const std::string table = eval::markdown_table({report});
    std::cout << table << std::flush;
    if (out_prefix.empty()) {
      if (!mapped_area_path.empty()) {
        spdlog::warn("--mapped-area only shades the plot, which needs --out");
      }
      return run.damaged ? 1 : 0;
    }
    const std::filesystem::path parent = std::filesystem::path(out_prefix).parent_path();
    if (!parent.empty()) {
      std::filesystem::create_directories(parent);
    }
    write_text(out_prefix + ".md", table);
    write_text(out_prefix + ".json", eval::to_json(report));
    write_text(out_prefix + ".T_gt_est.txt", format_transform(report.metrics.T_gt_est));
    eval::TrajectoryPlotInput plot;
    plot.ground_truth = ground_truth;
    plot.estimate = eval::transform_trajectory(report.metrics.T_gt_est, run.estimate);
    plot.modes = run.modes;
    if (!mapped_area_path.empty()) {
      plot.mapped_area = read_tum(mapped_area_path);
    }
    plot.title = eval::summary_line(report);
    if (!cv::imwrite(out_prefix + ".png", eval::render_trajectory_plot(plot, plot_config))) {
      throw std::runtime_error("cannot write " + out_prefix + ".png");
    }
    spdlog::info("wrote {}.md, .json, .png, .T_gt_est.txt", out_prefix);
    return run.damaged ? 1 : 0;
  });
}
