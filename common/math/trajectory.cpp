#include "math/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "math/se3.hpp"

namespace liloc {

Trajectory::Trajectory(std::vector<StampedPose> poses) : poses_(std::move(poses)) {
  std::stable_sort(poses_.begin(), poses_.end(),
                   [](const StampedPose& a, const StampedPose& b) { return a.time_s < b.time_s; });
  for (size_t i = 1; i < poses_.size(); ++i) {
    if (poses_[i].time_s == poses_[i - 1].time_s) {
      throw std::invalid_argument("trajectory has two poses at time " +
                                  std::to_string(poses_[i].time_s));
    }
  }
}

std::optional<Eigen::Isometry3d> Trajectory::at(double t, double max_gap_s) const {
  return lookup(t, max_gap_s).T;
}

TrajectoryLookup Trajectory::lookup(double t, double max_gap_s, double tolerance_s) const {
  TrajectoryLookup out;
  if (poses_.empty() || t < poses_.front().time_s - tolerance_s) {
    out.coverage = TrajectoryCoverage::kBeforeStart;
    return out;
  }
  if (t > poses_.back().time_s + tolerance_s) {
    out.coverage = TrajectoryCoverage::kAfterEnd;
    return out;
  }
  const auto after =
      std::lower_bound(poses_.begin(), poses_.end(), t,
                       [](const StampedPose& p, double time) { return p.time_s < time; });
  // The pose nearest in time, if it is within the tolerance.
  auto nearest = after == poses_.end() ? after - 1 : after;
  if (after != poses_.begin() && after != poses_.end() &&
      t - (after - 1)->time_s < after->time_s - t) {
    nearest = after - 1;
  }
  if (std::abs(nearest->time_s - t) <= tolerance_s) {
    out.T = nearest->T;
    return out;
  }
  const auto before = after - 1;
  const double gap = after->time_s - before->time_s;
  if (gap > max_gap_s) {
    out.coverage = TrajectoryCoverage::kInGap;
    out.gap_s = gap;
    return out;
  }
  out.T = se3::interpolate(before->T, after->T, (t - before->time_s) / gap);
  return out;
}

double Trajectory::path_length_m() const {
  double length = 0.0;
  for (size_t i = 1; i < poses_.size(); ++i) {
    length += (poses_[i].T.translation() - poses_[i - 1].T.translation()).norm();
  }
  return length;
}

}  // namespace liloc
