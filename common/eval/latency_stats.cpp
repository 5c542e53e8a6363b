#include "eval/latency_stats.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace liloc::eval {
namespace {
double quantile_of_sorted(const std::vector<double>& sorted, double p) {
  const double index = p * static_cast<double>(sorted.size() - 1);
  const size_t below = static_cast<size_t>(std::floor(index));
  const size_t above = std::min(below + 1, sorted.size() - 1);
  const double fraction = index - static_cast<double>(below);
  return sorted[below] + fraction * (sorted[above] - sorted[below]);
}
}  // namespace

LatencyStats compute_latency_stats(std::vector<double> cycle_ms) {
  if (cycle_ms.empty()) {
    throw std::invalid_argument("latency statistics of an empty list of cycle times");
  }
  if (!std::all_of(cycle_ms.begin(), cycle_ms.end(), [](double v) { return std::isfinite(v); })) {
    throw std::invalid_argument("latency statistics: a cycle time is not finite");
  }
  std::sort(cycle_ms.begin(), cycle_ms.end());
  LatencyStats stats;
  stats.count = cycle_ms.size();
  stats.median_ms = quantile_of_sorted(cycle_ms, 0.5);
  stats.p95_ms = quantile_of_sorted(cycle_ms, 0.95);
  stats.p99_ms = quantile_of_sorted(cycle_ms, 0.99);
  stats.max_ms = cycle_ms.back();
  stats.mean_ms =
      std::accumulate(cycle_ms.begin(), cycle_ms.end(), 0.0) / static_cast<double>(stats.count);
  return stats;
}

double quantile(std::vector<double> values, double p) {
  if (values.empty()) {
    return 0.0;
  }
  std::sort(values.begin(), values.end());
  return quantile_of_sorted(values, p);
}

}  // namespace liloc::eval
