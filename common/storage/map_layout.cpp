#include "storage/map_layout.hpp"

#include <charconv>
#include <cstdio>

namespace liloc::storage {
namespace {

std::string keyframe_file_stem(int64_t keyframe_id) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06lld", static_cast<long long>(keyframe_id));
  return std::string(kKeyframesDir) + "/" + name;
}

}  // namespace

std::string version_dir_name(int64_t version) {
  char name[32];
  std::snprintf(name, sizeof(name), "v%06lld", static_cast<long long>(version));
  return name;
}

std::optional<int64_t> parse_version_dir_name(std::string_view name) {
  if (name.size() < 7 || name.front() != 'v') {
    return std::nullopt;
  }
  int64_t version = 0;
  const char* first = name.data() + 1;
  const char* last = name.data() + name.size();
  const auto [end, error] = std::from_chars(first, last, version);
  if (error != std::errc() || end != last || version < 0 || version_dir_name(version) != name) {
    return std::nullopt;
  }
  return version;
}

std::string keyframe_cloud_path(int64_t keyframe_id) {
  return keyframe_file_stem(keyframe_id) + ".pcd";
}

std::string keyframe_descriptor_path(int64_t keyframe_id) {
  return keyframe_file_stem(keyframe_id) + ".desc";
}

}  // namespace liloc::storage
