#pragma once
// One evaluated run (trajectory metrics, optional latency and mode shares) and its
// output forms: a markdown table, a JSON object and a one-line summary.

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "eval/json_writer.hpp"
#include "eval/latency_stats.hpp"
#include "eval/trajectory_metrics.hpp"

namespace liloc::eval {

struct EvalReport {
  std::string name;
  TrajectoryMetrics metrics;
  // Absent when the run gave no per-cycle times: missing, not zero.
  std::optional<LatencyStats> latency;
  // ModeTimeline::time_fractions(); empty when the run gave no mode information.
  std::map<int, double> mode_time_fractions;
};

// Header, separator and one row per report. Mode and latency columns appear when any
// report has them; a report without them shows "-" there. NaN shows as "n/a".
std::string markdown_table(const std::vector<EvalReport>& reports);

// "name: ATE 0.123 m, xyz_rpy 0.0123, rot 0.456 deg, RPE 1.23 % 0.456 deg/100m"
// (plot titles, logs).
std::string summary_line(const EvalReport& report);

// The report as one JSON object, written at the writer's current position so that
// benchmark programs can embed it; optional parts are left out when absent.
void write_json(JsonWriter& json, const EvalReport& report);
std::string to_json(const EvalReport& report);

}  // namespace liloc::eval
