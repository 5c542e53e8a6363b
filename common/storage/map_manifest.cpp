#include "storage/map_manifest.hpp"

#include <yaml-cpp/yaml.h>

#include "map/map_validation.hpp"
#include "storage/file_io.hpp"
#include "storage/map_error.hpp"
#include "storage/map_layout.hpp"

namespace liloc::storage {
namespace {

constexpr std::string_view kChecksumKey = "manifest_crc32: ";

void append_files(std::string& out, const char* key, const std::vector<StoredFile>& files) {
  out += key;
  out += files.empty() ? ": []\n" : ":\n";
  for (const StoredFile& file : files) {
    out += "  - [" + file.path + ", " + std::to_string(file.size_bytes) + ", " +
           format_crc32(file.crc32) + "]\n";
  }
}

bool is_plain_file_name(std::string_view name) {
  if (name.empty() || name == "." || name == "..") {
    return false;
  }
  for (const char c : name) {
    const bool allowed = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                         (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-';
    if (!allowed) {
      return false;
    }
  }
  return true;
}

bool is_keyframe_file_path(std::string_view path) {
  const std::string prefix = std::string(kKeyframesDir) + "/";
  return path.substr(0, prefix.size()) == prefix && is_plain_file_name(path.substr(prefix.size()));
}

class ManifestReader {
 public:
  ManifestReader(const YAML::Node& root, const std::string& path) : root_(root), path_(path) {}

  [[noreturn]] void fail(const YAML::Node& node, const std::string& what) const {
    if (node.Mark().is_null()) {
      throw MapError::in_file(path_, what);
    }
    throw MapError::at_line(path_, node.Mark().line + 1, what);
  }

  YAML::Node required(const YAML::Node& parent, const char* key) const {
    const YAML::Node node = parent[key];
    if (!node) {
      fail(parent, std::string("missing key '") + key + "'");
    }
    return node;
  }

  template <class T>
  T value(const YAML::Node& parent, const char* key) const {
    const YAML::Node node = required(parent, key);
    try {
      if (!node.IsScalar()) {
        throw YAML::Exception(node.Mark(), "not a scalar");
      }
      return node.as<T>();
    } catch (const YAML::Exception&) {
      fail(node, std::string("key '") + key + "' has a value of the wrong type");
    }
  }

  std::vector<StoredFile> files(const char* key, bool keyframe_files) const {
    const YAML::Node list = required(root_, key);
    if (!list.IsSequence()) {
      fail(list, std::string("'") + key + "' must be a list");
    }
    std::vector<StoredFile> files;
    files.reserve(list.size());
    for (const YAML::Node& entry : list) {
      if (!entry.IsSequence() || entry.size() != 3 || !entry[0].IsScalar() ||
          !entry[1].IsScalar() || !entry[2].IsScalar()) {
        fail(entry, "a file entry must be [path, bytes, crc32]");
      }
      StoredFile file;
      file.path = entry[0].Scalar();
      const bool valid_path =
          keyframe_files ? is_keyframe_file_path(file.path) : is_plain_file_name(file.path);
      if (!valid_path) {
        fail(entry, "file path '" + file.path + "' is not a " +
                        (keyframe_files ? "keyframes/ file" : "file of the version directory"));
      }
      try {
        file.size_bytes = entry[1].as<uint64_t>();
      } catch (const YAML::Exception&) {
        fail(entry, "size of '" + file.path + "' is not a byte count");
      }
      const std::optional<uint32_t> crc = parse_crc32(entry[2].Scalar());
      if (!crc) {
        fail(entry, "crc32 of '" + file.path + "' is not 8 lower-case hex digits");
      }
      file.crc32 = *crc;
      files.push_back(std::move(file));
    }
    return files;
  }

 private:
  const YAML::Node& root_;
  const std::string& path_;
};

}  // namespace

std::string encode_manifest(const MapManifest& manifest) {
  std::string out;
  out.reserve(64 * (manifest.keyframe_files.size() + manifest.version_files.size()) + 1024);
  out +=
      "# liloc map version. Files: [path, bytes, crc32]; version_files relative to this\n"
      "# directory, keyframe_files relative to the map directory. The last line is the\n"
      "# CRC-32 of every byte before it.\n";
  out += std::string("format: ") + kMapFormatName + "\n";
  out += "format_version: " + std::to_string(manifest.format_version) + "\n";
  out += "map_id: " + manifest.map_id + "\n";
  out += "version: " + std::to_string(manifest.version) + "\n";
  out += "frame: " + manifest.frame + "\n";
  out += "created_utc: " + manifest.created_utc + "\n";
  out += "counts:\n";
  out += "  keyframes: " + std::to_string(manifest.counts.keyframes) + "\n";
  out += "  submaps: " + std::to_string(manifest.counts.submaps) + "\n";
  out += "  odometry_edges: " + std::to_string(manifest.counts.odometry_edges) + "\n";
  out += "  loop_edges: " + std::to_string(manifest.counts.loop_edges) + "\n";
  out += "  sessions: " + std::to_string(manifest.counts.sessions) + "\n";
  append_files(out, "version_files", manifest.version_files);
  append_files(out, "keyframe_files", manifest.keyframe_files);
  const uint32_t crc = crc32_of(out);
  out.append(kChecksumKey).append(format_crc32(crc)).append("\n");
  return out;
}

MapManifest parse_manifest(std::string_view bytes, const std::string& path) {
  // The checksum line is the last line: "\nmanifest_crc32: xxxxxxxx\n".
  const size_t line_start = bytes.rfind(std::string("\n").append(kChecksumKey));
  const size_t crc_start = line_start + 1 + kChecksumKey.size();
  if (line_start == std::string_view::npos || bytes.size() != crc_start + 9 ||
      bytes.back() != '\n') {
    throw MapError::in_file(path, "truncated or malformed: the last line must be '" +
                                      std::string(kChecksumKey) + "<crc32>'");
  }
  const std::optional<uint32_t> recorded = parse_crc32(bytes.substr(crc_start, 8));
  if (!recorded) {
    throw MapError::in_file(path, "malformed manifest_crc32");
  }
  const uint32_t actual = crc32_of(bytes.substr(0, line_start + 1));
  if (actual != *recorded) {
    throw MapError::in_file(path, "checksum mismatch (manifest_crc32 " + format_crc32(*recorded) +
                                      ", content " + format_crc32(actual) + ")");
  }

  YAML::Node root;
  try {
    root = YAML::Load(std::string(bytes));
  } catch (const YAML::Exception& e) {
    throw MapError::at_line(path, e.mark.line + 1, e.msg);
  }
  if (!root.IsMap()) {
    throw MapError::in_file(path, "not a YAML map");
  }
  const ManifestReader reader(root, path);
  const std::string format = reader.value<std::string>(root, "format");
  if (format != kMapFormatName) {
    reader.fail(root["format"], "format '" + format + "' is not " + kMapFormatName);
  }
  MapManifest manifest;
  manifest.format_version = reader.value<int>(root, "format_version");
  if (manifest.format_version != kMapFormatVersion) {
    reader.fail(root["format_version"], "format_version " +
                                            std::to_string(manifest.format_version) +
                                            " is not the one this program reads (" +
                                            std::to_string(kMapFormatVersion) + ")");
  }
  manifest.map_id = reader.value<std::string>(root, "map_id");
  if (!is_valid_map_id(manifest.map_id)) {
    reader.fail(root["map_id"], "invalid map_id '" + manifest.map_id + "'");
  }
  manifest.version = reader.value<int64_t>(root, "version");
  manifest.frame = reader.value<std::string>(root, "frame");
  if (manifest.frame != kMapFrame) {
    reader.fail(root["frame"], "frame '" + manifest.frame + "' is not '" + kMapFrame + "'");
  }
  manifest.created_utc = reader.value<std::string>(root, "created_utc");
  const YAML::Node counts = reader.required(root, "counts");
  manifest.counts.keyframes = reader.value<int64_t>(counts, "keyframes");
  manifest.counts.submaps = reader.value<int64_t>(counts, "submaps");
  manifest.counts.odometry_edges = reader.value<int64_t>(counts, "odometry_edges");
  manifest.counts.loop_edges = reader.value<int64_t>(counts, "loop_edges");
  manifest.counts.sessions = reader.value<int64_t>(counts, "sessions");
  manifest.version_files = reader.files("version_files", false);
  manifest.keyframe_files = reader.files("keyframe_files", true);
  return manifest;
}

}  // namespace liloc::storage
