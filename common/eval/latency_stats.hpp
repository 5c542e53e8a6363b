#pragma once
// Statistics of per-cycle processing times (status_t timing "total"), milliseconds.

#include <cstddef>
#include <vector>

namespace liloc::eval {

struct LatencyStats {
  size_t count = 0;
  double median_ms = 0.0;
  double p95_ms = 0.0;
  double p99_ms = 0.0;
  double max_ms = 0.0;
  double mean_ms = 0.0;
};

// Percentiles interpolate linearly between the closest ranks (numpy's default): the
// p-quantile of the sorted values v[0..n-1] is v at fractional index p * (n - 1).
// Throws std::invalid_argument if cycle_ms is empty or holds a non-finite value.
LatencyStats compute_latency_stats(std::vector<double> cycle_ms);

// The p-quantile of values (as above); 0 for an empty list.
double quantile(std::vector<double> values, double p);

}  // namespace liloc::eval
