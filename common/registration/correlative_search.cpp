#include "registration/correlative_search.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "math/so3.hpp"
#include "pointcloud/voxel_grid.hpp"

namespace liloc {
namespace {

constexpr double kDeg = 3.141592653589793 / 180.0;

}  // namespace

void CorrelativeSearchConfig::validate() const {
  if (!(cell_m > 0) || !(yaw_step_deg > 0) || max_points < 10 || peaks < 1 || !(distinct_m > 0) ||
      !(distinct_deg > 0)) {
    throw std::invalid_argument(
        "correlative search: cell_m, yaw_step_deg, distinct_m and distinct_deg must be positive, "
        "max_points at least 10, peaks at least 1");
  }
}

CorrelativeSearch::CorrelativeSearch(const std::vector<Eigen::Vector3f>& map_points,
                                     const CorrelativeSearchConfig& config)
    : config_(config), occupied_(map_points.size() / 4 + 16) {
  config_.validate();
  const float cell = static_cast<float>(config_.cell_m);
  for (const Eigen::Vector3f& p : map_points) {
    occupied_.insert(voxel_key(voxel_index(p, cell)));
  }
}

std::vector<ScoredPose> CorrelativeSearch::search(const std::vector<Eigen::Vector3f>& points_body,
                                                  const Eigen::Matrix3d& R_level_body,
                                                  const SearchWindow& window) const {
  // A whole stride keeps between max_points and twice as many: the initializer's and the
  // odometry's thresholds were measured so. Capped exactly (evenly_spaced), VLP-16 campus C's
  // coarse initialization accepted a wrong pose (1 of 47, bench_init 2026-11-25); the exact
  // cap wants max_points raised and measured again.
  std::vector<Eigen::Vector3f> points;
  const size_t stride =
      std::max<size_t>(1, points_body.size() / static_cast<size_t>(config_.max_points));
  for (size_t i = 0; i < points_body.size(); i += stride) {
    points.push_back(points_body[i]);
  }
  if (points.empty() || occupied_.size() == 0) {
    return {};
  }
  const int shifts = static_cast<int>(std::ceil(window.half_xy_m / config_.cell_m));
  const int yaws = static_cast<int>(std::ceil(window.half_yaw_rad / (config_.yaw_step_deg * kDeg)));
  const Eigen::Vector3f centre(static_cast<float>(window.x_m), static_cast<float>(window.y_m),
                               static_cast<float>(window.z_m));
  const float cell = static_cast<float>(config_.cell_m);
  struct Entry {
    int hits, yaw, dx, dy;
  };
  std::vector<Entry> entries;
  entries.reserve(static_cast<size_t>((2 * yaws + 1) * (2 * shifts + 1) * (2 * shifts + 1)));
  std::vector<Eigen::Vector3i> cells(points.size());
  for (int k = -yaws; k <= yaws; ++k) {
    const double yaw = window.yaw_rad + k * config_.yaw_step_deg * kDeg;
    const Eigen::Matrix3f R = (so3::exp(Eigen::Vector3d(0, 0, yaw)) * R_level_body).cast<float>();
    for (size_t i = 0; i < points.size(); ++i) {
      cells[i] = voxel_index(R * points[i] + centre, cell);
    }
    // A shift by whole cells moves every point's cell by the same integer offset.
    for (int dx = -shifts; dx <= shifts; ++dx) {
      for (int dy = -shifts; dy <= shifts; ++dy) {
        int hits = 0;
        for (const Eigen::Vector3i& c : cells) {
          hits += occupied_.find(voxel_key(c + Eigen::Vector3i(dx, dy, 0))) !=
                  VoxelIndexTable::kMissing;
        }
        entries.push_back({hits, k, dx, dy});
      }
    }
  }
  std::sort(entries.begin(), entries.end(),
            [](const Entry& a, const Entry& b) { return a.hits > b.hits; });
  std::vector<Entry> peaks;
  for (const Entry& e : entries) {
    if (static_cast<int>(peaks.size()) >= config_.peaks) {
      break;
    }
    const bool near_peak = std::any_of(peaks.begin(), peaks.end(), [&](const Entry& p) {
      return std::hypot(p.dx - e.dx, p.dy - e.dy) * config_.cell_m < config_.distinct_m &&
             std::abs(p.yaw - e.yaw) * config_.yaw_step_deg < config_.distinct_deg;
    });
    if (!near_peak) {
      peaks.push_back(e);
    }
  }
  std::vector<ScoredPose> out;
  for (const Entry& e : peaks) {
    ScoredPose pose;
    const double yaw = window.yaw_rad + e.yaw * config_.yaw_step_deg * kDeg;
    pose.T_map_body.linear() = so3::exp(Eigen::Vector3d(0, 0, yaw)) * R_level_body;
    pose.T_map_body.translation() = Eigen::Vector3d(window.x_m + e.dx * config_.cell_m,
                                                    window.y_m + e.dy * config_.cell_m, window.z_m);
    pose.score = static_cast<double>(e.hits) / points.size();
    out.push_back(pose);
  }
  return out;
}

}  // namespace liloc
