#pragma once
// The incremental local map of the odometry: points in a hash of voxels, each voxel
// holding at most max_points_per_voxel points kept at least min_point_spacing_m apart.
// Memory is bounded twice: per voxel, and by dropping voxels beyond a radius around the
// sensor (remove_far), so that it stays flat over long runs.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <vector>

#include "pointcloud/voxel_index_table.hpp"

namespace liloc {

struct VoxelMapConfig {
  double voxel_m = 1.0;
  int max_points_per_voxel = 20;
  // Map points closer than this add nothing but sampling patterns and noise to the
  // planes fitted through them.
  double min_point_spacing_m = 0.3;
  double keep_radius_m = 150.0;  // remove_far() drops voxels farther than this

  template <class V>
  void visit_fields(V& v) {
    v("voxel_m", voxel_m);
    v("max_points_per_voxel", max_points_per_voxel);
    v("min_point_spacing_m", min_point_spacing_m);
    v("keep_radius_m", keep_radius_m);
  }
  void validate() const;
};

// The direction from a map point toward the sensor that saw it, as a unit vector times
// 127; zero where it is not known (points inserted without their sensor).
using ViewDirection = Eigen::Matrix<int8_t, 3, 1>;

// Up to K nearest map points of a query, nearest first.
template <int K>
struct Neighbors {
  std::array<Eigen::Vector3f, K> points;
  std::array<ViewDirection, K> views;
  std::array<float, K> squared_distances;
  int count = 0;
};

class VoxelHashMap {
 public:
  static constexpr int kMaxPointsPerVoxel = 20;

  explicit VoxelHashMap(const VoxelMapConfig& config);

  // Adds points (map frame); a point is dropped if its voxel is full or holds a point
  // closer than min_point_spacing_m.
  void insert(const std::vector<Eigen::Vector3f>& points) { insert(points.data(), points.size()); }
  void insert(const Eigen::Vector3f* points, size_t count);
  // The same, for points seen from sensor_origin (map frame): each keeps its view direction.
  void insert(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3f& sensor_origin);
  // Adds every point of `other`, moved into this map's frame by T_this_other.
  void insert(const VoxelHashMap& other, const Eigen::Isometry3f& T_this_other);

  // The k nearest points within max_distance_m of q among the 8 voxels around q: exact
  // within voxel_m / 2, approximate beyond.
  template <int K>
  Neighbors<K> nearest(const Eigen::Vector3f& q, float max_distance_m) const;

  // Drops voxels whose centre is farther than keep_radius_m from `center`.
  void remove_far(const Eigen::Vector3d& center);

  size_t num_voxels() const { return voxels_.size(); }
  size_t num_points() const { return num_points_; }
  bool empty() const { return num_points_ == 0; }
  std::vector<Eigen::Vector3f> points() const;
  const VoxelMapConfig& config() const { return config_; }

 private:
  struct Voxel {
    int count = 0;
    std::array<Eigen::Vector3f, kMaxPointsPerVoxel> points;
    std::array<ViewDirection, kMaxPointsPerVoxel> views;
  };

  Eigen::Vector3i index_of(const Eigen::Vector3f& p) const;
  void insert_one(const Eigen::Vector3f& p, const ViewDirection& view);

  VoxelMapConfig config_;
  float inv_voxel_;
  float min_spacing_sq_;       // min_point_spacing_m squared, for the insertion of every point
  VoxelIndexTable index_;      // voxel key -> index into voxels_
  std::vector<Voxel> voxels_;  // dense, in index order
  size_t num_points_ = 0;
};

}  // namespace liloc

#include "voxel_map/voxel_hash_map_impl.hpp"
