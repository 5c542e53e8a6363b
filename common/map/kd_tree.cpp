#include "map/kd_tree.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace liloc {
namespace {
constexpr size_t kLeafSize = 8;
}

KdTree::KdTree(std::vector<Item> items) : items_(std::move(items)) {
  if (!items_.empty()) {
    nodes_.reserve(2 * items_.size() / kLeafSize + 2);
    build(0, items_.size());
  }
}

int KdTree::build(size_t begin, size_t end) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  if (end - begin <= kLeafSize) {
    nodes_[index].begin = begin;
    nodes_[index].end = end;
    return index;
  }
  // Split along the widest extent at the median.
  Eigen::Vector3d lo = items_[begin].position, hi = lo;
  for (size_t i = begin; i < end; ++i) {
    lo = lo.cwiseMin(items_[i].position);
    hi = hi.cwiseMax(items_[i].position);
  }
  int axis = 0;
  (hi - lo).maxCoeff(&axis);
  const size_t mid = begin + (end - begin) / 2;
  std::nth_element(
      items_.begin() + static_cast<long>(begin), items_.begin() + static_cast<long>(mid),
      items_.begin() + static_cast<long>(end),
      [axis](const Item& a, const Item& b) { return a.position[axis] < b.position[axis]; });
  nodes_[index].axis = axis;
  nodes_[index].split = items_[mid].position[axis];
  const int left = build(begin, mid);
  const int right = build(mid, end);
  nodes_[index].left = left;
  nodes_[index].right = right;
  return index;
}

template <class Visit>
void KdTree::search(int node_index, const Eigen::Vector3d& q, double& bound_sq,
                    Visit&& visit) const {
  const Node& node = nodes_[node_index];
  if (node.axis < 0) {
    for (size_t i = node.begin; i < node.end; ++i) {
      visit(items_[i], (items_[i].position - q).squaredNorm());
    }
    return;
  }
  const double diff = q[node.axis] - node.split;
  const int near = diff < 0 ? node.left : node.right;
  const int far = diff < 0 ? node.right : node.left;
  search(near, q, bound_sq, visit);
  if (diff * diff <= bound_sq) {
    search(far, q, bound_sq, visit);
  }
}

std::vector<KdTree::Hit> KdTree::nearest(const Eigen::Vector3d& q, size_t k) const {
  std::vector<Hit> best;  // sorted by distance, at most k
  if (items_.empty() || k == 0) {
    return best;
  }
  double bound_sq = std::numeric_limits<double>::infinity();
  search(0, q, bound_sq, [&](const Item& item, double d2) {
    if (best.size() == k && d2 >= bound_sq) {
      return;
    }
    const Hit hit{item.id, std::sqrt(d2)};
    best.insert(
        std::upper_bound(best.begin(), best.end(), hit,
                         [](const Hit& a, const Hit& b) { return a.distance < b.distance; }),
        hit);
    if (best.size() > k) {
      best.pop_back();
    }
    if (best.size() == k) {
      bound_sq = best.back().distance * best.back().distance;
    }
  });
  return best;
}

std::vector<KdTree::Hit> KdTree::within(const Eigen::Vector3d& q, double radius) const {
  std::vector<Hit> hits;
  if (items_.empty()) {
    return hits;
  }
  double bound_sq = radius * radius;
  search(0, q, bound_sq, [&](const Item& item, double d2) {
    if (d2 <= radius * radius) {
      hits.push_back({item.id, std::sqrt(d2)});
    }
  });
  std::sort(hits.begin(), hits.end(),
            [](const Hit& a, const Hit& b) { return a.distance < b.distance; });
  return hits;
}

}  // namespace liloc
