#pragma once
// The text files of a map version (docs/map_format.md), encoded from and parsed into the
// in-memory map. Numbers are written in the shortest form that reads back to the same
// double, so a save of a loaded map writes the same values. Parsers name the file and
// line of the first problem; they receive the bytes whose checksum the caller verified.

#include <string>
#include <string_view>
#include <vector>

#include "map/map_types.hpp"

namespace liloc::storage {

// keyframes.csv: id, utime_us, session, submap_id, fitness_m, cloud file, descriptor file.
std::string encode_keyframes_csv(const std::vector<MapKeyframe>& keyframes);
// Poses are left at identity (they are in poses.tum). The file columns must name the
// keyframe's own files (keyframe_cloud_path / keyframe_descriptor_path).
std::vector<MapKeyframe> parse_keyframes_csv(std::string_view text, const std::string& path);

// poses.tum: T_map_body of each keyframe, in keyframes.csv order, time = utime_us exactly.
std::string encode_poses_tum(const std::vector<MapKeyframe>& keyframes);
// Sets T_map_body of `keyframes`; line k must carry the time of keyframes[k].
void parse_poses_tum(std::string_view text, const std::string& path,
                     std::vector<MapKeyframe>& keyframes);

// submaps.csv: id, source_session, centroid, xy bounds, keyframe ids (space separated).
std::string encode_submaps_csv(const std::vector<Submap>& submaps);
std::vector<Submap> parse_submaps_csv(std::string_view text, const std::string& path);

// pose_graph.g2o: VERTEX_SE3:QUAT per keyframe, EDGE_SE3:QUAT per edge ending in
// "# odometry" or "# loop". The information matrix is converted to g2o's convention
// (rotation error = quaternion vector part, half the angle), so g2o tools weigh the
// edges as liloc does.
std::string encode_pose_graph_g2o(const std::vector<MapKeyframe>& keyframes,
                                  const std::vector<PoseGraphEdge>& edges);
// The vertices must be the keyframes, in order; their poses are not read back (poses.tum
// is the record of the poses).
std::vector<PoseGraphEdge> parse_pose_graph_g2o(std::string_view text, const std::string& path,
                                                const std::vector<MapKeyframe>& keyframes);

}  // namespace liloc::storage
