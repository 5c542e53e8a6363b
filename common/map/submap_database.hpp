#pragma once
// Adaptive submap joining (paper Section IV-A) and the queries on the central session:
// Tree_p over keyframe (prior pose) positions, Tree_m over submap centroids, and the
// overlap of a pose's neighbourhood with a submap (Eq. 11) that switches RLM and ILM.

#include <optional>
#include <vector>

#include "map/kd_tree.hpp"
#include "map/map_types.hpp"

namespace liloc {

struct SubmapConfig {
  int max_keyframes = 20;           // N_s (paper)
  double max_translation_m = 20.0;  // h_p (paper)
  // A submap's bounds are its keyframes' positions grown by this margin: the area its
  // keyframes observed well (a LiDAR sees further, but sparsely).
  double bounds_margin_m = 15.0;

  template <class V>
  void visit_fields(V& v) {
    v("max_keyframes", max_keyframes);
    v("max_translation_m", max_translation_m);
    v("bounds_margin_m", bounds_margin_m);
  }
  void validate() const;
};

// Eq. 2: consecutive keyframes (one session, in order) are joined into submaps; submap
// M_k closes at keyframe k when it holds N_s keyframes (k - j >= N_s) or keyframe k is
// h_p from the last pose T_j of the previous submap. Ids count up from first_submap_id;
// the keyframes' submap_id is set.
std::vector<Submap> join_submaps(std::vector<MapKeyframe>& keyframes, const SubmapConfig& config,
                                 int64_t first_submap_id);

// Centroid and bounds of a submap from its keyframes' positions (map frame).
void set_submap_geometry(Submap& submap, const std::vector<Eigen::Vector3d>& keyframe_positions,
                         const SubmapConfig& config);

// Eq. 11: the overlap, the fraction of the square [x +- l, y +- l] around `position` that lies in
// the bounds.
double overlap_ratio(const Eigen::Vector3d& position, double half_side_m, const BoundsXY& bounds);

class SubmapDatabase {
 public:
  SubmapDatabase() = default;
  explicit SubmapDatabase(const MapData& map);

  // Tree_m: the submaps whose centroids are nearest to `position`.
  std::vector<KdTree::Hit> nearest_submaps(const Eigen::Vector3d& position, size_t k) const {
    return tree_m_.nearest(position, k);
  }
  std::vector<KdTree::Hit> submaps_within(const Eigen::Vector3d& position, double radius) const {
    return tree_m_.within(position, radius);
  }
  // Tree_p: the keyframes (prior nodes) nearest to `position` (N_d = 3 for scan match).
  std::vector<KdTree::Hit> nearest_keyframes(const Eigen::Vector3d& position, size_t k) const {
    return tree_p_.nearest(position, k);
  }

  const Submap* submap(int64_t id) const;
  const MapKeyframe* keyframe(int64_t id) const;

 private:
  const MapData* map_ = nullptr;
  KdTree tree_p_;
  KdTree tree_m_;
  std::vector<std::pair<int64_t, size_t>> submap_index_;    // (id, index), sorted by id
  std::vector<std::pair<int64_t, size_t>> keyframe_index_;  // (id, index), sorted by id
};

}  // namespace liloc
