#pragma once
// A static 3D kd-tree over identified points: the paper's Tree_p (prior keyframe
// positions) and Tree_m (submap centroids). Built once per map change; queries are
// exact k-nearest and radius searches.

#include <Eigen/Core>
#include <cstdint>
#include <utility>
#include <vector>

namespace liloc {

class KdTree {
 public:
  struct Item {
    int64_t id;
    Eigen::Vector3d position;
  };
  struct Hit {
    int64_t id;
    double distance;
  };

  KdTree() = default;
  explicit KdTree(std::vector<Item> items);

  // The k nearest items, nearest first (fewer if the tree is smaller).
  std::vector<Hit> nearest(const Eigen::Vector3d& q, size_t k) const;
  // Every item within radius, nearest first.
  std::vector<Hit> within(const Eigen::Vector3d& q, double radius) const;

  size_t size() const { return items_.size(); }
  bool empty() const { return items_.empty(); }

 private:
  struct Node {
    int axis = -1;  // -1: leaf
    double split = 0.0;
    int left = -1, right = -1;
    size_t begin = 0, end = 0;  // items_[begin, end) for leaves
  };
  int build(size_t begin, size_t end);
  template <class Visit>
  void search(int node, const Eigen::Vector3d& q, double& bound_sq, Visit&& visit) const;

  std::vector<Item> items_;
  std::vector<Node> nodes_;
};

}  // namespace liloc
