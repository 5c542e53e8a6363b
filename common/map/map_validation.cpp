#include "map/map_validation.hpp"

#include <cmath>
#include <unordered_set>

namespace liloc {
namespace {

constexpr size_t kMaxNameLength = 64;

bool is_alphanumeric(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9');
}

bool is_placed(const Eigen::Isometry3d& T) {
  return is_rigid(T) && T.translation().cwiseAbs().maxCoeff() <= kMaxMapCoordinateM;
}

std::string bad_name(const std::string& owner, const std::string& name) {
  return owner + ": session '" + printable_excerpt(name) +
         "' is empty, longer than 64 characters or has a ',', '\"' or control character";
}

}  // namespace

bool is_valid_name(std::string_view name) {
  if (name.empty() || name.size() > kMaxNameLength) {
    return false;
  }
  for (const char c : name) {
    if (c == ',' || c == '"' || static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
      return false;
    }
  }
  return true;
}

bool is_valid_map_id(std::string_view map_id) {
  if (map_id.empty() || !is_alphanumeric(map_id.front())) {
    return false;
  }
  for (const char c : map_id) {
    if (!is_alphanumeric(c) && c != '.' && c != '_' && c != '-') {
      return false;
    }
  }
  return true;
}

bool is_rigid(const Eigen::Isometry3d& T) {
  const Eigen::Matrix3d R = T.linear();
  return T.matrix().allFinite() &&
         (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-6 &&
         R.determinant() > 0.0;
}

std::string printable_excerpt(std::string_view text) {
  std::string out;
  for (const char c : text.substr(0, 40)) {
    out += (c >= 0x20 && c < 0x7f) ? c : '?';
  }
  return text.size() > 40 ? out + "..." : out;
}

std::optional<MapProblem> find_map_problem(const MapData& map) {
  std::unordered_set<int64_t> keyframe_ids;
  for (size_t i = 0; i < map.keyframes.size(); ++i) {
    const MapKeyframe& kf = map.keyframes[i];
    const std::string name = "keyframe " + std::to_string(kf.id);
    if (kf.id < 0) {
      return MapProblem{MapPart::kKeyframes, name + ": ids must not be negative"};
    }
    if (i > 0 && kf.id <= map.keyframes[i - 1].id) {
      return MapProblem{MapPart::kKeyframes, name + " after keyframe " +
                                                 std::to_string(map.keyframes[i - 1].id) +
                                                 ": keyframes must be in increasing id order"};
    }
    if (!is_valid_name(kf.session)) {
      return MapProblem{MapPart::kKeyframes, bad_name(name, kf.session)};
    }
    if (!std::isfinite(kf.fitness_m)) {
      return MapProblem{MapPart::kKeyframes, name + ": fitness_m is not finite"};
    }
    if (!is_placed(kf.T_map_body)) {
      return MapProblem{MapPart::kPoses, name +
                                             ": T_map_body is not a finite rigid transform "
                                             "within 10^7 m of the origin"};
    }
    keyframe_ids.insert(kf.id);
  }
  std::unordered_set<int64_t> submap_ids;
  for (size_t i = 0; i < map.submaps.size(); ++i) {
    const Submap& submap = map.submaps[i];
    const std::string name = "submap " + std::to_string(submap.id);
    if (submap.id < 0 || (i > 0 && submap.id <= map.submaps[i - 1].id)) {
      return MapProblem{MapPart::kSubmaps,
                        name + ": submap ids must not be negative and in increasing order"};
    }
    if (!is_valid_name(submap.source_session)) {
      return MapProblem{MapPart::kSubmaps, bad_name(name, submap.source_session)};
    }
    const BoundsXY& b = submap.bounds;
    if (!submap.centroid.allFinite() || !std::isfinite(b.min_x) || !std::isfinite(b.max_x) ||
        !std::isfinite(b.min_y) || !std::isfinite(b.max_y)) {
      return MapProblem{MapPart::kSubmaps, name + ": centroid or bounds not finite"};
    }
    for (const int64_t id : submap.keyframe_ids) {
      if (keyframe_ids.count(id) == 0) {
        return MapProblem{MapPart::kSubmaps, name + " lists keyframe " + std::to_string(id) +
                                                 ", which the map does not have"};
      }
    }
    submap_ids.insert(submap.id);
  }
  for (const MapKeyframe& kf : map.keyframes) {
    if (kf.submap_id != -1 && submap_ids.count(kf.submap_id) == 0) {
      return MapProblem{MapPart::kKeyframes, "keyframe " + std::to_string(kf.id) +
                                                 " is in submap " + std::to_string(kf.submap_id) +
                                                 ", which the map does not have (-1: none)"};
    }
  }
  for (const PoseGraphEdge& edge : map.edges) {
    const std::string name = "edge " + std::to_string(edge.from) + " -> " + std::to_string(edge.to);
    if (keyframe_ids.count(edge.from) == 0 || keyframe_ids.count(edge.to) == 0) {
      return MapProblem{MapPart::kPoseGraph, name + " joins a keyframe the map does not have"};
    }
    if (!is_placed(edge.T_from_to) || !edge.information.allFinite()) {
      return MapProblem{MapPart::kPoseGraph,
                        name + ": T_from_to or information not finite (or not rigid)"};
    }
  }
  return std::nullopt;
}

}  // namespace liloc
