#include "eval/eval_report.hpp"

#include <cmath>
#include <cstdio>

#include "eval/mode_timeline.hpp"

namespace liloc::eval {
namespace {
std::string fixed(double value, int decimals) {
  if (!std::isfinite(value)) {
    return "n/a";
  }
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", decimals, value);
  return buffer;
}

double mode_percent(const EvalReport& report, int mode) {
  const auto it = report.mode_time_fractions.find(mode);
  return it == report.mode_time_fractions.end() ? 0.0 : 100.0 * it->second;
}

std::string table_line(const std::vector<std::string>& cells) {
  std::string line = "|";
  for (const std::string& cell : cells) {
    line += " " + cell + " |";
  }
  return line + "\n";
}
}  // namespace

std::string markdown_table(const std::vector<EvalReport>& reports) {
  bool any_modes = false;
  bool any_latency = false;
  for (const EvalReport& r : reports) {
    any_modes = any_modes || !r.mode_time_fractions.empty();
    any_latency = any_latency || r.latency.has_value();
  }
  std::vector<std::string> header = {"name",    "align",          "matched",    "skipped",
                                     "ATE (m)", "max (m)",        "xyz_rpy",    "rot RMSE (deg)",
                                     "RPE (%)", "RPE (deg/100m)", "length (m)", "duration (s)"};
  if (any_modes) {
    header.insert(header.end(), {"RLM (%)", "ILM (%)"});
  }
  if (any_latency) {
    header.insert(header.end(),
                  {"cycles", "median (ms)", "p95 (ms)", "p99 (ms)", "max (ms)", "mean (ms)"});
  }
  std::string table = table_line(header);
  table += table_line(std::vector<std::string>(header.size(), "---"));
  for (const EvalReport& r : reports) {
    const TrajectoryMetrics& m = r.metrics;
    std::vector<std::string> row = {r.name,
                                    to_string(m.alignment),
                                    std::to_string(m.matched_poses),
                                    std::to_string(m.skipped_poses),
                                    fixed(m.ate_position_rmse_m, 3),
                                    fixed(m.ate_position_max_m, 3),
                                    fixed(m.ate_full_rmse, 4),
                                    fixed(m.rotation_rmse_deg, 3),
                                    fixed(m.rpe_translation_percent, 3),
                                    fixed(m.rpe_rotation_deg_per_100m, 3),
                                    fixed(m.path_length_m, 1),
                                    fixed(m.duration_s, 1)};
    if (any_modes) {
      if (r.mode_time_fractions.empty()) {
        row.insert(row.end(), {"-", "-"});
      } else {
        row.insert(row.end(),
                   {fixed(mode_percent(r, kModeRlm), 1), fixed(mode_percent(r, kModeIlm), 1)});
      }
    }
    if (any_latency) {
      if (r.latency) {
        const LatencyStats& l = *r.latency;
        row.insert(row.end(), {std::to_string(l.count), fixed(l.median_ms, 2), fixed(l.p95_ms, 2),
                               fixed(l.p99_ms, 2), fixed(l.max_ms, 2), fixed(l.mean_ms, 2)});
      } else {
        row.insert(row.end(), 6, "-");
      }
    }
    table += table_line(row);
  }
  return table;
}

std::string summary_line(const EvalReport& report) {
  const TrajectoryMetrics& m = report.metrics;
  return report.name + ": ATE " + fixed(m.ate_position_rmse_m, 3) + " m, xyz_rpy " +
         fixed(m.ate_full_rmse, 4) + ", rot " + fixed(m.rotation_rmse_deg, 3) + " deg, RPE " +
         fixed(m.rpe_translation_percent, 2) + " % " + fixed(m.rpe_rotation_deg_per_100m, 3) +
         " deg/100m (" + to_string(m.alignment) + " alignment)";
}

void write_json(JsonWriter& json, const EvalReport& report) {
  const TrajectoryMetrics& m = report.metrics;
  json.begin_object();
  json.key("name").string(report.name);
  json.key("alignment").string(to_string(m.alignment));
  json.key("T_gt_est").begin_array();
  for (int row = 0; row < 4; ++row) {
    json.begin_array();
    for (int col = 0; col < 4; ++col) {
      json.number(m.T_gt_est.matrix()(row, col));
    }
    json.end_array();
  }
  json.end_array();
  json.key("matched_poses").integer(static_cast<int64_t>(m.matched_poses));
  json.key("skipped_poses").integer(static_cast<int64_t>(m.skipped_poses));
  json.key("ate_position_rmse_m").number(m.ate_position_rmse_m);
  json.key("ate_position_max_m").number(m.ate_position_max_m);
  json.key("ate_full_rmse").number(m.ate_full_rmse);
  json.key("rotation_rmse_deg").number(m.rotation_rmse_deg);
  json.key("rpe_segment_m").number(m.rpe_segment_m);
  json.key("rpe_segments").integer(static_cast<int64_t>(m.rpe_segments));
  json.key("rpe_translation_percent").number(m.rpe_translation_percent);
  json.key("rpe_rotation_deg_per_100m").number(m.rpe_rotation_deg_per_100m);
  json.key("path_length_m").number(m.path_length_m);
  json.key("duration_s").number(m.duration_s);
  if (!report.mode_time_fractions.empty()) {
    json.key("mode_time_fraction").begin_object();
    for (const auto& [mode, fraction] : report.mode_time_fractions) {
      json.key(mode_name(mode)).number(fraction);
    }
    json.end_object();
  }
  if (report.latency) {
    const LatencyStats& l = *report.latency;
    json.key("latency_ms").begin_object();
    json.key("count").integer(static_cast<int64_t>(l.count));
    json.key("median").number(l.median_ms);
    json.key("p95").number(l.p95_ms);
    json.key("p99").number(l.p99_ms);
    json.key("max").number(l.max_ms);
    json.key("mean").number(l.mean_ms);
    json.end_object();
  }
  json.key("warnings").begin_array();
  for (const std::string& warning : m.warnings) {
    json.string(warning);
  }
  json.end_array();
  json.end_object();
}

std::string to_json(const EvalReport& report) {
  JsonWriter json;
  write_json(json, report);
  return json.str();
}

}  // namespace liloc::eval
