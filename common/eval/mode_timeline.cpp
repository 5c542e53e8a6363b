#include "eval/mode_timeline.hpp"

#include <algorithm>

namespace liloc::eval {

std::string mode_name(int mode) {
  switch (mode) {
    case kModeNone:
      return "none";
    case kModeInitializing:
      return "initializing";
    case kModeRlm:
      return "rlm";
    case kModeIlm:
      return "ilm";
    case kModeLost:
      return "lost";
    default:
      return "mode_" + std::to_string(mode);
  }
}

ModeTimeline::ModeTimeline(std::vector<ModeSample> samples) : samples_(std::move(samples)) {
  std::stable_sort(samples_.begin(), samples_.end(),
                   [](const ModeSample& a, const ModeSample& b) { return a.time_s < b.time_s; });
}

std::optional<int> ModeTimeline::mode_at(double t) const {
  const auto after =
      std::upper_bound(samples_.begin(), samples_.end(), t,
                       [](double time, const ModeSample& s) { return time < s.time_s; });
  if (after == samples_.begin()) {
    return std::nullopt;
  }
  return (after - 1)->mode;
}

std::map<int, double> ModeTimeline::time_fractions() const {
  if (samples_.empty() || samples_.back().time_s <= samples_.front().time_s) {
    return {};
  }
  std::map<int, double> seconds;
  for (size_t i = 0; i + 1 < samples_.size(); ++i) {
    seconds[samples_[i].mode] += samples_[i + 1].time_s - samples_[i].time_s;
  }
  const double span = samples_.back().time_s - samples_.front().time_s;
  for (auto& [mode, s] : seconds) {
    s /= span;
  }
  return seconds;
}

}  // namespace liloc::eval
