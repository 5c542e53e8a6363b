#pragma once
// Roads as a graph of intersections (nodes) and straight road segments (edges).
// Vehicles drive on the right-hand lane.

#include <Eigen/Core>
#include <utility>
#include <vector>

namespace liloc::sim {

class RoadNetwork {
 public:
  RoadNetwork() = default;
  RoadNetwork(std::vector<Eigen::Vector2d> nodes, std::vector<std::pair<int, int>> edges,
              double road_width_m, double lane_offset_m);

  const std::vector<Eigen::Vector2d>& nodes() const { return nodes_; }
  const std::vector<std::pair<int, int>>& edges() const { return edges_; }
  const std::vector<int>& neighbors(int node) const { return neighbors_[node]; }
  double road_width_m() const { return road_width_m_; }
  double lane_offset_m() const { return lane_offset_m_; }

  double distance(int a, int b) const { return (nodes_[a] - nodes_[b]).norm(); }
  // Dijkstra over edge lengths; empty if unreachable. Nodes for which allowed(node) is
  // false are never entered (except `from` and `to`).
  template <class Allowed>
  std::vector<int> shortest_path(int from, int to, Allowed allowed) const;
  std::vector<int> shortest_path(int from, int to) const {
    return shortest_path(from, to, [](int) { return true; });
  }
  int nearest_node(const Eigen::Vector2d& p) const;
  // Distance from p to the nearest road centre line, metres.
  double distance_to_road(const Eigen::Vector2d& p) const;

 private:
  std::vector<Eigen::Vector2d> nodes_;
  std::vector<std::pair<int, int>> edges_;
  std::vector<std::vector<int>> neighbors_;
  double road_width_m_ = 10.0;
  double lane_offset_m_ = 2.0;
};

}  // namespace liloc::sim

#include "sim/road_network_impl.hpp"
