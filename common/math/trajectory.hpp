#pragma once
// A time-ordered sequence of poses T_frame_body, with interpolation. Used for ground
// truth and estimates (evaluation, simulation, map building).

#include <Eigen/Geometry>
#include <optional>
#include <vector>

namespace liloc {

struct StampedPose {
  double time_s = 0.0;  // seconds since the Unix epoch (or since the session start)
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
};

// Where a time falls on a trajectory: callers that match sensor data to poses report why
// a time got none.
enum class TrajectoryCoverage { kCovered, kBeforeStart, kAfterEnd, kInGap };

struct TrajectoryLookup {
  std::optional<Eigen::Isometry3d> T;
  TrajectoryCoverage coverage = TrajectoryCoverage::kCovered;
  double gap_s = 0.0;  // for kInGap: how far apart the poses around the time are
};

class Trajectory {
 public:
  Trajectory() = default;
  // Sorts by time; throws std::invalid_argument if two poses share a timestamp.
  explicit Trajectory(std::vector<StampedPose> poses);

  const std::vector<StampedPose>& poses() const { return poses_; }
  size_t size() const { return poses_.size(); }
  bool empty() const { return poses_.empty(); }
  double start_time() const { return poses_.front().time_s; }
  double end_time() const { return poses_.back().time_s; }

  // Pose at time t, interpolated between the poses around it (se3::interpolate), or
  // nullopt if t lies outside the trajectory or the poses around it are more than
  // max_gap_s apart.
  std::optional<Eigen::Isometry3d> at(double t, double max_gap_s) const;
  // As at(), and a time within tolerance_s of a pose takes that pose, also just outside
  // the span: times that went through another clock's rounding (microseconds, a log's
  // fixed decimals) still meet the pose recorded for them.
  TrajectoryLookup lookup(double t, double max_gap_s, double tolerance_s = 0.0) const;

  // Length of the path of the positions, metres.
  double path_length_m() const;

 private:
  std::vector<StampedPose> poses_;
};

}  // namespace liloc
