#pragma once
// The central session in memory: keyframes with their poses in the map frame, submaps
// (runs of consecutive keyframes, paper Eq. 2) and the pose graph they were optimized in.
// Keyframe clouds are held separately (storage/ loads them on demand), so that the
// metadata of a large map stays small.

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "math/se3.hpp"
#include "pointcloud/point_cloud.hpp"

namespace liloc {

struct MapKeyframe {
  int64_t id = 0;        // unique in the map
  int64_t utime_us = 0;  // time of the scan
  std::string session;   // session that recorded it ("A", robot/session id ...)
  Eigen::Isometry3d T_map_body = Eigen::Isometry3d::Identity();
  double fitness_m = 0.0;  // registration fitness when it was recorded
  int64_t submap_id = -1;
};

// Axis-aligned bounds in the map's xy plane, metres.
struct BoundsXY {
  double min_x = 0.0, max_x = 0.0, min_y = 0.0, max_y = 0.0;
  double area() const { return std::max(0.0, max_x - min_x) * std::max(0.0, max_y - min_y); }
};

struct Submap {
  int64_t id = 0;
  std::vector<int64_t> keyframe_ids;                   // consecutive keyframes of one session
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  // of the keyframe positions
  BoundsXY bounds;                                     // of the well-observed area
  std::string source_session;
};

struct PoseGraphEdge {
  enum class Kind : uint8_t { kOdometry, kLoop };
  int64_t from = 0;  // keyframe ids
  int64_t to = 0;
  Eigen::Isometry3d T_from_to = Eigen::Isometry3d::Identity();
  // 6x6 information over the right perturbation (translation m, rotation rad).
  Matrix6d information = Matrix6d::Identity();
  Kind kind = Kind::kOdometry;
};

// Everything of a map but the keyframe clouds.
struct MapData {
  std::string map_id = "liloc-map";
  int64_t version = 0;                 // +1 for each saved change
  std::vector<MapKeyframe> keyframes;  // in id order
  std::vector<Submap> submaps;         // in id order
  std::vector<PoseGraphEdge> edges;
};

// A change that grows a map (a merged update): keyframes, submaps and edges appended to
// it, with the new keyframes' clouds (body frame), shared with whoever serves them.
struct MapDelta {
  std::vector<MapKeyframe> keyframes;
  std::vector<Submap> submaps;
  std::vector<PoseGraphEdge> edges;
  std::map<int64_t, std::shared_ptr<const PointCloud>> clouds;  // by keyframe id
  std::map<int64_t, std::vector<uint8_t>> descriptors;          // encoded, by keyframe id

  // Appends this change to a map (MapData) or to an earlier change (MapDelta).
  template <class Target>
  void append_to(Target& target) const {
    target.keyframes.insert(target.keyframes.end(), keyframes.begin(), keyframes.end());
    target.submaps.insert(target.submaps.end(), submaps.begin(), submaps.end());
    target.edges.insert(target.edges.end(), edges.begin(), edges.end());
    if constexpr (std::is_same_v<Target, MapDelta>) {
      target.clouds.insert(clouds.begin(), clouds.end());
      target.descriptors.insert(descriptors.begin(), descriptors.end());
    }
  }
};

}  // namespace liloc
