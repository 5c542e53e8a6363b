#pragma once
// The rules every map follows, in one place: storage checks them when it loads a map and
// before it saves one, the map service before it merges a robot's update, so that nothing
// the server accepts can fail to save.

#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <string_view>

#include "map/map_types.hpp"

namespace liloc {

// The part of a map a problem lies in (storage names the file that holds it).
enum class MapPart { kKeyframes, kPoses, kSubmaps, kPoseGraph };

struct MapProblem {
  MapPart part = MapPart::kKeyframes;
  std::string what;
};

// Session and robot names: they go into the map's CSV files unquoted, so not empty, at
// most 64 characters, and no ',', '"' or control character.
bool is_valid_name(std::string_view name);
// A map id: letters, digits, '.', '_' or '-', starting with a letter or digit.
bool is_valid_map_id(std::string_view map_id);
// Finite, with an orthonormal rotation of determinant +1.
bool is_rigid(const Eigen::Isometry3d& T);
// Up to 40 characters of text that may be binary garbage, printable (for messages).
std::string printable_excerpt(std::string_view text);

// The first problem of `map`, or none: ids not negative and increasing, names valid,
// values finite and poses rigid (positions within max_coordinate_m of the origin),
// submaps and edges naming keyframes the map has, keyframes in submaps it has.
std::optional<MapProblem> find_map_problem(const MapData& map);

// Positions beyond this (m) are refused: no vehicle maps 10^4 km, and squares of larger
// coordinates lose the precision that submap bounds and kd-trees need.
inline constexpr double kMaxMapCoordinateM = 1e7;

}  // namespace liloc
