#pragma once
// Template part of road_network.hpp.

#include <algorithm>
#include <functional>
#include <limits>
#include <queue>

namespace liloc::sim {

template <class Allowed>
std::vector<int> RoadNetwork::shortest_path(int from, int to, Allowed allowed) const {
  const int n = static_cast<int>(nodes_.size());
  std::vector<double> dist(n, std::numeric_limits<double>::infinity());
  std::vector<int> previous(n, -1);
  using Entry = std::pair<double, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  dist[from] = 0.0;
  open.push({0.0, from});
  while (!open.empty()) {
    const auto [d, u] = open.top();
    open.pop();
    if (d > dist[u]) {
      continue;
    }
    if (u == to) {
      break;
    }
    for (const int v : neighbors_[u]) {
      if (v != to && !allowed(v)) {
        continue;
      }
      const double nd = d + distance(u, v);
      if (nd < dist[v]) {
        dist[v] = nd;
        previous[v] = u;
        open.push({nd, v});
      }
    }
  }
  if (from != to && previous[to] < 0) {
    return {};
  }
  std::vector<int> path;
  for (int v = to; v != -1; v = previous[v]) {
    path.push_back(v);
    if (v == from) {
      break;
    }
  }
  std::reverse(path.begin(), path.end());
  return path;
}

}  // namespace liloc::sim
