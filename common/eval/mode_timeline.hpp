#pragma once
// The localization mode over time, from (time, mode) samples of a status stream: which
// mode was active at a pose's time (plot colours) and the share of time in each mode.

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace liloc::eval {

// The values of status_t::MODE_* (lcmtypes/status_t.lcm), repeated here because common/
// algorithm code does not include LCM types; liloc_eval static_asserts that they match.
constexpr int kModeNone = 0;
constexpr int kModeInitializing = 1;
constexpr int kModeRlm = 2;  // relocalization in mapped area
constexpr int kModeIlm = 3;  // incremental localization, the map grows
constexpr int kModeLost = 4;

// "none", "initializing", "rlm", "ilm", "lost", or "mode_<n>" for any other value.
std::string mode_name(int mode);

struct ModeSample {
  double time_s = 0.0;
  int mode = kModeNone;
};

class ModeTimeline {
 public:
  ModeTimeline() = default;
  // Sorts by time; of samples with equal times the later one in the input wins.
  explicit ModeTimeline(std::vector<ModeSample> samples);

  bool empty() const { return samples_.empty(); }
  const std::vector<ModeSample>& samples() const { return samples_; }

  // Mode of the latest sample at or before t (a status reports the mode from its time
  // on), or nullopt before the first sample.
  std::optional<int> mode_at(double t) const;

  // Share of the time from the first to the last sample spent in each mode (a sample's
  // mode lasts until the next sample), keyed by mode value and summing to 1. Empty when
  // the samples span no time (fewer than two distinct times): no share can be given.
  std::map<int, double> time_fractions() const;

 private:
  std::vector<ModeSample> samples_;
};

}  // namespace liloc::eval
