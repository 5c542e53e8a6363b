#include "storage/map_text_files.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "map/map_validation.hpp"
#include "storage/map_error.hpp"
#include "storage/map_layout.hpp"

namespace liloc::storage {
namespace {

constexpr std::string_view kKeyframesHeader =
    "id,utime_us,session,submap_id,fitness_m,cloud_file,descriptor_file";
constexpr std::string_view kSubmapsHeader =
    "id,source_session,centroid_x_m,centroid_y_m,centroid_z_m,min_x_m,max_x_m,min_y_m,max_y_m,"
    "keyframe_ids";
constexpr std::string_view kVertexTag = "VERTEX_SE3:QUAT";
constexpr std::string_view kEdgeTag = "EDGE_SE3:QUAT";
constexpr std::string_view kOdometryKind = "odometry";
constexpr std::string_view kLoopKind = "loop";
constexpr int kInformationEntries = 21;  // upper triangle of 6x6
constexpr int64_t kMicrosecondsPerSecond = 1000000;

// g2o's rotation error is the quaternion's vector part, half liloc's angle: the
// information over it is S * information * S with S = diag(1, 1, 1, 2, 2, 2).
constexpr double g2o_scale(int i) { return i < 3 ? 1.0 : 2.0; }

void append_number(std::string& out, double value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  out.append(buffer, result.ptr);
}

void append_number(std::string& out, int64_t value) {
  char buffer[24];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  out.append(buffer, result.ptr);
}

void append_pose(std::string& out, const Eigen::Isometry3d& T) {
  const Eigen::Quaterniond q(T.rotation());
  const Eigen::Vector3d& t = T.translation();
  for (const double value : {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()}) {
    out += ' ';
    append_number(out, value);
  }
}

// "1700000000.123456": the exact utime, no rounding through a double.
void append_utime_as_seconds(std::string& out, int64_t utime_us) {
  char buffer[48];
  const uint64_t magnitude =
      utime_us < 0 ? 0 - static_cast<uint64_t>(utime_us) : static_cast<uint64_t>(utime_us);
  std::snprintf(buffer, sizeof(buffer), "%s%llu.%06llu", utime_us < 0 ? "-" : "",
                static_cast<unsigned long long>(magnitude / kMicrosecondsPerSecond),
                static_cast<unsigned long long>(magnitude % kMicrosecondsPerSecond));
  out += buffer;
}

// Lines of a text file with their numbers; skips blank lines and '#' comments.
class LineScanner {
 public:
  LineScanner(std::string_view text, const std::string& path) : text_(text), path_(path) {}

  bool next(std::string_view& line) {
    while (position_ < text_.size()) {
      size_t end = text_.find('\n', position_);
      if (end == std::string_view::npos) {
        end = text_.size();
      }
      line = text_.substr(position_, end - position_);
      position_ = end + 1;
      ++line_number_;
      const size_t first = line.find_first_not_of(" \t");
      if (first != std::string_view::npos && line[first] != '#') {
        return true;
      }
    }
    return false;
  }

  [[noreturn]] void fail(const std::string& what) const {
    throw MapError::at_line(path_, line_number_, what);
  }

  // The first content line must be `header` exactly.
  void expect_header(std::string_view header) {
    std::string_view line;
    if (!next(line)) {
      throw MapError::in_file(path_,
                              "empty (expected the header line '" + std::string(header) + "')");
    }
    if (line != header) {
      fail("expected the header line '" + std::string(header) + "'");
    }
  }

  // ',' splits at every comma; ' ' at runs of spaces and tabs.
  static std::vector<std::string_view> split(std::string_view line, char separator) {
    std::vector<std::string_view> fields;
    if (separator == ' ') {
      size_t position = 0;
      while (true) {
        const size_t first = line.find_first_not_of(" \t", position);
        if (first == std::string_view::npos) {
          break;
        }
        size_t last = line.find_first_of(" \t", first);
        if (last == std::string_view::npos) {
          last = line.size();
        }
        fields.push_back(line.substr(first, last - first));
        position = last;
      }
      return fields;
    }
    size_t position = 0;
    while (true) {
      const size_t end = line.find(separator, position);
      if (end == std::string_view::npos) {
        fields.push_back(line.substr(position));
        return fields;
      }
      fields.push_back(line.substr(position, end - position));
      position = end + 1;
    }
  }

  std::vector<std::string_view> fields(std::string_view line, char separator,
                                       size_t expected) const {
    std::vector<std::string_view> result = split(line, separator);
    if (result.size() != expected) {
      fail("expected " + std::to_string(expected) + " fields, found " +
           std::to_string(result.size()));
    }
    return result;
  }

  int64_t integer(std::string_view field, const char* name) const {
    int64_t value = 0;
    const auto [end, error] = std::from_chars(field.data(), field.data() + field.size(), value);
    if (field.empty() || error != std::errc() || end != field.data() + field.size()) {
      fail(std::string(name) + " '" + std::string(field) + "' is not an integer");
    }
    return value;
  }

  double number(std::string_view field, const char* name) const {
    double value = 0.0;
    const auto [end, error] = std::from_chars(field.data(), field.data() + field.size(), value);
    if (field.empty() || error != std::errc() || end != field.data() + field.size()) {
      fail(std::string(name) + " '" + std::string(field) + "' is not a number");
    }
    if (!std::isfinite(value)) {
      fail(std::string(name) + " is not finite");
    }
    return value;
  }

  std::string session(std::string_view field) const {
    if (!is_valid_name(field)) {
      fail("invalid session name '" + std::string(field) + "'");
    }
    return std::string(field);
  }

  // "tx ty tz qx qy qz qw" at fields[first ...].
  Eigen::Isometry3d pose(const std::vector<std::string_view>& fields, size_t first) const {
    double v[7];
    for (int i = 0; i < 7; ++i) {
      v[i] = number(fields[first + i], "pose value");
    }
    const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
    if (std::abs(q.norm() - 1.0) > 1e-6) {
      fail("quaternion norm " + std::to_string(q.norm()) + " is not 1");
    }
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = q.normalized().toRotationMatrix();
    T.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
    return T;
  }

  int64_t utime_from_seconds(std::string_view field) const {
    const size_t dot = field.find('.');
    const std::string_view fraction =
        dot == std::string_view::npos ? std::string_view() : field.substr(dot + 1);
    if (dot == std::string_view::npos || fraction.size() != 6 ||
        fraction.find_first_not_of("0123456789") != std::string_view::npos) {
      fail("time '" + std::string(field) + "' is not seconds with 6 decimals");
    }
    const bool negative = !field.empty() && field.front() == '-';
    const std::string_view whole = field.substr(negative ? 1 : 0, dot - (negative ? 1 : 0));
    if (whole.empty() || whole.find_first_not_of("0123456789") != std::string_view::npos) {
      fail("time '" + std::string(field) + "' is not seconds with 6 decimals");
    }
    const int64_t magnitude =
        integer(whole, "time") * kMicrosecondsPerSecond + integer(fraction, "time");
    return negative ? -magnitude : magnitude;
  }

 private:
  std::string_view text_;
  const std::string& path_;
  size_t position_ = 0;
  int64_t line_number_ = 0;
};

}  // namespace

std::string encode_keyframes_csv(const std::vector<MapKeyframe>& keyframes) {
  std::string out;
  out.reserve(80 * (keyframes.size() + 1));
  out.append(kKeyframesHeader).append("\n");
  for (const MapKeyframe& kf : keyframes) {
    append_number(out, kf.id);
    out += ',';
    append_number(out, kf.utime_us);
    out += ',';
    out += kf.session;
    out += ',';
    append_number(out, kf.submap_id);
    out += ',';
    append_number(out, kf.fitness_m);
    out += ',';
    out += keyframe_cloud_path(kf.id);
    out += ',';
    out += keyframe_descriptor_path(kf.id);
    out += '\n';
  }
  return out;
}

std::vector<MapKeyframe> parse_keyframes_csv(std::string_view text, const std::string& path) {
  LineScanner scanner(text, path);
  scanner.expect_header(kKeyframesHeader);
  std::vector<MapKeyframe> keyframes;
  std::string_view line;
  while (scanner.next(line)) {
    const auto f = scanner.fields(line, ',', 7);
    MapKeyframe kf;
    kf.id = scanner.integer(f[0], "id");
    kf.utime_us = scanner.integer(f[1], "utime_us");
    kf.session = scanner.session(f[2]);
    kf.submap_id = scanner.integer(f[3], "submap_id");
    kf.fitness_m = scanner.number(f[4], "fitness_m");
    if (f[5] != keyframe_cloud_path(kf.id)) {
      scanner.fail("cloud file '" + std::string(f[5]) + "' is not " + keyframe_cloud_path(kf.id));
    }
    if (f[6] != keyframe_descriptor_path(kf.id)) {
      scanner.fail("descriptor file '" + std::string(f[6]) + "' is not " +
                   keyframe_descriptor_path(kf.id));
    }
    keyframes.push_back(std::move(kf));
  }
  return keyframes;
}

std::string encode_poses_tum(const std::vector<MapKeyframe>& keyframes) {
  std::string out;
  out.reserve(140 * (keyframes.size() + 1));
  out += "# T_map_body of each keyframe, in keyframes.csv order. time_s tx ty tz qx qy qz qw\n";
  for (const MapKeyframe& kf : keyframes) {
    append_utime_as_seconds(out, kf.utime_us);
    append_pose(out, kf.T_map_body);
    out += '\n';
  }
  return out;
}

void parse_poses_tum(std::string_view text, const std::string& path,
                     std::vector<MapKeyframe>& keyframes) {
  LineScanner scanner(text, path);
  std::string_view line;
  size_t index = 0;
  while (scanner.next(line)) {
    if (index == keyframes.size()) {
      scanner.fail("more poses than the " + std::to_string(keyframes.size()) +
                   " keyframes of keyframes.csv");
    }
    const auto f = scanner.fields(line, ' ', 8);
    MapKeyframe& kf = keyframes[index++];
    if (scanner.utime_from_seconds(f[0]) != kf.utime_us) {
      scanner.fail("time " + std::string(f[0]) + " is not the time of keyframe " +
                   std::to_string(kf.id) + " (utime_us " + std::to_string(kf.utime_us) +
                   " in keyframes.csv)");
    }
    kf.T_map_body = scanner.pose(f, 1);
  }
  if (index != keyframes.size()) {
    throw MapError::in_file(path, std::to_string(index) + " poses for " +
                                      std::to_string(keyframes.size()) +
                                      " keyframes in keyframes.csv");
  }
}

std::string encode_submaps_csv(const std::vector<Submap>& submaps) {
  std::string out;
  out.append(kSubmapsHeader).append("\n");
  for (const Submap& submap : submaps) {
    append_number(out, submap.id);
    out += ',';
    out += submap.source_session;
    for (const double value :
         {submap.centroid.x(), submap.centroid.y(), submap.centroid.z(), submap.bounds.min_x,
          submap.bounds.max_x, submap.bounds.min_y, submap.bounds.max_y}) {
      out += ',';
      append_number(out, value);
    }
    out += ',';
    for (size_t k = 0; k < submap.keyframe_ids.size(); ++k) {
      if (k > 0) {
        out += ' ';
      }
      append_number(out, submap.keyframe_ids[k]);
    }
    out += '\n';
  }
  return out;
}

std::vector<Submap> parse_submaps_csv(std::string_view text, const std::string& path) {
  LineScanner scanner(text, path);
  scanner.expect_header(kSubmapsHeader);
  std::vector<Submap> submaps;
  std::string_view line;
  while (scanner.next(line)) {
    const auto f = scanner.fields(line, ',', 10);
    Submap submap;
    submap.id = scanner.integer(f[0], "id");
    submap.source_session = scanner.session(f[1]);
    submap.centroid =
        Eigen::Vector3d(scanner.number(f[2], "centroid_x_m"), scanner.number(f[3], "centroid_y_m"),
                        scanner.number(f[4], "centroid_z_m"));
    submap.bounds.min_x = scanner.number(f[5], "min_x_m");
    submap.bounds.max_x = scanner.number(f[6], "max_x_m");
    submap.bounds.min_y = scanner.number(f[7], "min_y_m");
    submap.bounds.max_y = scanner.number(f[8], "max_y_m");
    for (const std::string_view id : LineScanner::split(f[9], ' ')) {
      submap.keyframe_ids.push_back(scanner.integer(id, "keyframe id"));
    }
    submaps.push_back(std::move(submap));
  }
  return submaps;
}

std::string encode_pose_graph_g2o(const std::vector<MapKeyframe>& keyframes,
                                  const std::vector<PoseGraphEdge>& edges) {
  std::string out;
  out.reserve(120 * keyframes.size() + 400 * edges.size() + 400);
  out +=
      "# liloc pose graph. Vertices: keyframes, T_map_body. Edges: T_from_to with the upper\n"
      "# triangle of the information matrix in g2o's convention (translation, quaternion\n"
      "# vector part). Each edge ends with its kind: '# odometry' or '# loop'.\n";
  for (const MapKeyframe& kf : keyframes) {
    out.append(kVertexTag).append(" ");
    append_number(out, kf.id);
    append_pose(out, kf.T_map_body);
    out += '\n';
  }
  for (const PoseGraphEdge& edge : edges) {
    out.append(kEdgeTag).append(" ");
    append_number(out, edge.from);
    out += ' ';
    append_number(out, edge.to);
    append_pose(out, edge.T_from_to);
    for (int i = 0; i < 6; ++i) {
      for (int j = i; j < 6; ++j) {
        out += ' ';
        append_number(out, edge.information(i, j) * g2o_scale(i) * g2o_scale(j));
      }
    }
    out += " # ";
    out.append(edge.kind == PoseGraphEdge::Kind::kLoop ? kLoopKind : kOdometryKind);
    out += '\n';
  }
  return out;
}

std::vector<PoseGraphEdge> parse_pose_graph_g2o(std::string_view text, const std::string& path,
                                                const std::vector<MapKeyframe>& keyframes) {
  LineScanner scanner(text, path);
  std::vector<PoseGraphEdge> edges;
  size_t vertices = 0;
  std::string_view line;
  while (scanner.next(line)) {
    const std::vector<std::string_view> f = LineScanner::split(line, ' ');
    if (f.front() == kVertexTag) {
      if (!edges.empty()) {
        scanner.fail("vertex after the first edge");
      }
      if (f.size() != 9) {
        scanner.fail("expected 9 fields, found " + std::to_string(f.size()));
      }
      const int64_t id = scanner.integer(f[1], "vertex id");
      if (vertices == keyframes.size() || keyframes[vertices].id != id) {
        scanner.fail("vertex " + std::to_string(id) + " is not keyframe " +
                     (vertices < keyframes.size() ? std::to_string(keyframes[vertices].id)
                                                  : std::string("(none left)")) +
                     " of keyframes.csv");
      }
      scanner.pose(f, 2);
      ++vertices;
    } else if (f.front() == kEdgeTag) {
      constexpr size_t kFields = 3 + 7 + kInformationEntries + 2;
      if (f.size() != kFields) {
        scanner.fail("expected " + std::to_string(kFields) + " fields (ending in '# " +
                     std::string(kOdometryKind) + "' or '# " + std::string(kLoopKind) +
                     "'), found " + std::to_string(f.size()));
      }
      PoseGraphEdge edge;
      edge.from = scanner.integer(f[1], "edge from");
      edge.to = scanner.integer(f[2], "edge to");
      edge.T_from_to = scanner.pose(f, 3);
      size_t k = 10;
      for (int i = 0; i < 6; ++i) {
        for (int j = i; j < 6; ++j) {
          const double value =
              scanner.number(f[k++], "information") / (g2o_scale(i) * g2o_scale(j));
          edge.information(i, j) = value;
          edge.information(j, i) = value;
        }
      }
      if (f[k] != "#" || (f[k + 1] != kOdometryKind && f[k + 1] != kLoopKind)) {
        scanner.fail("edge must end with '# " + std::string(kOdometryKind) + "' or '# " +
                     std::string(kLoopKind) + "'");
      }
      edge.kind =
          f[k + 1] == kLoopKind ? PoseGraphEdge::Kind::kLoop : PoseGraphEdge::Kind::kOdometry;
      edges.push_back(edge);
    } else {
      scanner.fail("unknown record '" + std::string(f.front()) + "'");
    }
  }
  if (vertices != keyframes.size()) {
    throw MapError::in_file(path, std::to_string(vertices) + " vertices for " +
                                      std::to_string(keyframes.size()) +
                                      " keyframes in keyframes.csv");
  }
  return edges;
}

}  // namespace liloc::storage
