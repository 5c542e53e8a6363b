#pragma once
// Names inside a map directory (docs/map_format.md):
//
//   CURRENT                      name of the current version directory
//   LOCK                         flock(2) target that serializes save() and prune()
//   versions/v000012/            one immutable directory per saved version
//   keyframes/000123.pcd|.desc   keyframe files, written once, shared by versions

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace liloc::storage {

inline constexpr const char* kCurrentFile = "CURRENT";
inline constexpr const char* kLockFile = "LOCK";
inline constexpr const char* kVersionsDir = "versions";
inline constexpr const char* kKeyframesDir = "keyframes";
// Suffix of anything not yet committed (or being deleted); prune() removes these.
inline constexpr const char* kTempSuffix = ".tmp";

inline constexpr const char* kManifestFile = "manifest.yaml";
inline constexpr const char* kKeyframesCsvFile = "keyframes.csv";
inline constexpr const char* kPosesTumFile = "poses.tum";
inline constexpr const char* kSubmapsCsvFile = "submaps.csv";
inline constexpr const char* kPoseGraphFile = "pose_graph.g2o";

// "v000012" for version 12 (at least six digits).
std::string version_dir_name(int64_t version);
// 12 for "v000012"; nullopt for anything else (temporary names, stray files).
std::optional<int64_t> parse_version_dir_name(std::string_view name);

// Relative to the map directory: "keyframes/000123.pcd", "keyframes/000123.desc".
std::string keyframe_cloud_path(int64_t keyframe_id);
std::string keyframe_descriptor_path(int64_t keyframe_id);

}  // namespace liloc::storage
