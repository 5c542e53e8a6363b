#pragma once
// manifest.yaml of a map version: what the version is and, for every file it consists
// of, the size and CRC-32 that load() checks. Its last line is its own checksum
// ("manifest_crc32: ..." over every byte before that line), so a damaged manifest is
// detected too.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace liloc::storage {

inline constexpr const char* kMapFormatName = "liloc-map";
inline constexpr int kMapFormatVersion = 1;
inline constexpr const char* kMapFrame = "map";

struct StoredFile {
  // Version files: relative to the version directory ("poses.tum"); keyframe files:
  // relative to the map directory ("keyframes/000123.pcd").
  std::string path;
  uint64_t size_bytes = 0;
  uint32_t crc32 = 0;
};

struct MapCounts {
  int64_t keyframes = 0;
  int64_t submaps = 0;
  int64_t odometry_edges = 0;
  int64_t loop_edges = 0;
  int64_t sessions = 0;  // distinct sessions of the keyframes
};

struct MapManifest {
  int format_version = kMapFormatVersion;
  std::string map_id;
  int64_t version = 0;
  std::string frame = kMapFrame;
  std::string created_utc;  // ISO 8601, e.g. "2025-06-01T12:00:00Z"
  MapCounts counts;
  std::vector<StoredFile> version_files;
  std::vector<StoredFile> keyframe_files;  // cloud and descriptor of every keyframe
};

std::string encode_manifest(const MapManifest& manifest);

// Checks the trailing checksum, the format name and version, the frame, and that every
// path is one this format writes (no absolute paths, no "..": a manifest cannot make
// load() read outside the map directory). Throws MapError naming `path`.
MapManifest parse_manifest(std::string_view bytes, const std::string& path);

}  // namespace liloc::storage
