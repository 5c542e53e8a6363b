#include "map/submap_database.hpp"

#include <algorithm>
#include <stdexcept>

namespace liloc {

void SubmapConfig::validate() const {
  if (max_keyframes < 1 || max_translation_m <= 0.0 || bounds_margin_m < 0.0) {
    throw std::invalid_argument(
        "max_keyframes must be >= 1, max_translation_m positive, bounds_margin_m >= 0");
  }
}

void set_submap_geometry(Submap& submap, const std::vector<Eigen::Vector3d>& keyframe_positions,
                         const SubmapConfig& config) {
  if (keyframe_positions.empty()) {
    throw std::invalid_argument("submap " + std::to_string(submap.id) + " has no keyframe");
  }
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Vector2d lo = keyframe_positions.front().head<2>(), hi = lo;
  for (const Eigen::Vector3d& p : keyframe_positions) {
    sum += p;
    lo = lo.cwiseMin(p.head<2>());
    hi = hi.cwiseMax(p.head<2>());
  }
  submap.centroid = sum / static_cast<double>(keyframe_positions.size());
  submap.bounds = {lo.x() - config.bounds_margin_m, hi.x() + config.bounds_margin_m,
                   lo.y() - config.bounds_margin_m, hi.y() + config.bounds_margin_m};
}

std::vector<Submap> join_submaps(std::vector<MapKeyframe>& keyframes, const SubmapConfig& config,
                                 int64_t first_submap_id) {
  config.validate();
  std::vector<Submap> submaps;
  Submap current;
  std::vector<Eigen::Vector3d> positions;
  // T_j: the last pose of the previous submap (the first keyframe starts the first one).
  Eigen::Vector3d last_of_previous = Eigen::Vector3d::Zero();
  if (!keyframes.empty()) {
    last_of_previous = keyframes.front().T_map_body.translation();
  }
  const auto close = [&]() {
    current.id = first_submap_id + static_cast<int64_t>(submaps.size());
    current.source_session = keyframes.front().session;
    set_submap_geometry(current, positions, config);
    submaps.push_back(current);
    current = Submap{};
    positions.clear();
  };
  for (MapKeyframe& kf : keyframes) {
    current.keyframe_ids.push_back(kf.id);
    positions.push_back(kf.T_map_body.translation());
    kf.submap_id = first_submap_id + static_cast<int64_t>(submaps.size());
    const bool full = static_cast<int>(current.keyframe_ids.size()) >= config.max_keyframes;
    const bool far =
        (kf.T_map_body.translation() - last_of_previous).norm() >= config.max_translation_m;
    if (full || far) {
      last_of_previous = kf.T_map_body.translation();
      close();
    }
  }
  if (!current.keyframe_ids.empty()) {
    close();
  }
  return submaps;
}

double overlap_ratio(const Eigen::Vector3d& position, double half_side_m, const BoundsXY& bounds) {
  const double x0 = std::max(position.x() - half_side_m, bounds.min_x);
  const double x1 = std::min(position.x() + half_side_m, bounds.max_x);
  const double y0 = std::max(position.y() - half_side_m, bounds.min_y);
  const double y1 = std::min(position.y() + half_side_m, bounds.max_y);
  if (x1 <= x0 || y1 <= y0) {
    return 0.0;
  }
  return (x1 - x0) * (y1 - y0) / (4.0 * half_side_m * half_side_m);
}

SubmapDatabase::SubmapDatabase(const MapData& map) : map_(&map) {
  std::vector<KdTree::Item> keyframe_items, submap_items;
  for (size_t i = 0; i < map.keyframes.size(); ++i) {
    keyframe_items.push_back({map.keyframes[i].id, map.keyframes[i].T_map_body.translation()});
    keyframe_index_.emplace_back(map.keyframes[i].id, i);
  }
  for (size_t i = 0; i < map.submaps.size(); ++i) {
    submap_items.push_back({map.submaps[i].id, map.submaps[i].centroid});
    submap_index_.emplace_back(map.submaps[i].id, i);
  }
  std::sort(keyframe_index_.begin(), keyframe_index_.end());
  std::sort(submap_index_.begin(), submap_index_.end());
  tree_p_ = KdTree(std::move(keyframe_items));
  tree_m_ = KdTree(std::move(submap_items));
}

const Submap* SubmapDatabase::submap(int64_t id) const {
  const auto it =
      std::lower_bound(submap_index_.begin(), submap_index_.end(), std::make_pair(id, size_t{0}));
  return it != submap_index_.end() && it->first == id ? &map_->submaps[it->second] : nullptr;
}

const MapKeyframe* SubmapDatabase::keyframe(int64_t id) const {
  const auto it = std::lower_bound(keyframe_index_.begin(), keyframe_index_.end(),
                                   std::make_pair(id, size_t{0}));
  return it != keyframe_index_.end() && it->first == id ? &map_->keyframes[it->second] : nullptr;
}

}  // namespace liloc
