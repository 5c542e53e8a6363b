#include "sim/road_network.hpp"

namespace liloc::sim {

RoadNetwork::RoadNetwork(std::vector<Eigen::Vector2d> nodes, std::vector<std::pair<int, int>> edges,
                         double road_width_m, double lane_offset_m)
    : nodes_(std::move(nodes)),
      edges_(std::move(edges)),
      neighbors_(nodes_.size()),
      road_width_m_(road_width_m),
      lane_offset_m_(lane_offset_m) {
  for (const auto& [a, b] : edges_) {
    neighbors_[a].push_back(b);
    neighbors_[b].push_back(a);
  }
}

int RoadNetwork::nearest_node(const Eigen::Vector2d& p) const {
  int best = -1;
  double best_d = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < nodes_.size(); ++i) {
    const double d = (nodes_[i] - p).squaredNorm();
    if (d < best_d) {
      best_d = d;
      best = static_cast<int>(i);
    }
  }
  return best;
}

double RoadNetwork::distance_to_road(const Eigen::Vector2d& p) const {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& [a, b] : edges_) {
    const Eigen::Vector2d ab = nodes_[b] - nodes_[a];
    const double s = std::clamp((p - nodes_[a]).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (nodes_[a] + s * ab - p).norm());
  }
  return best;
}

}  // namespace liloc::sim
