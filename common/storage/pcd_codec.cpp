#include "storage/pcd_codec.hpp"

#include <charconv>
#include <cstring>

#include "storage/map_error.hpp"

namespace liloc::storage {
namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "PCD binary data is little-endian; this host would need byte swapping");

constexpr size_t kBytesPerPoint = 4 * sizeof(float);

std::string header_for(size_t points) {
  const std::string n = std::to_string(points);
  return "# .PCD v0.7 - Point Cloud Data file format\n"
         "VERSION 0.7\n"
         "FIELDS x y z intensity\n"
         "SIZE 4 4 4 4\n"
         "TYPE F F F F\n"
         "COUNT 1 1 1 1\n"
         "WIDTH " +
         n +
         "\n"
         "HEIGHT 1\n"
         "VIEWPOINT 0 0 0 1 0 0 0\n"
         "POINTS " +
         n +
         "\n"
         "DATA binary\n";
}

}  // namespace

std::string encode_pcd(const PointCloud& cloud) {
  std::string bytes = header_for(cloud.size());
  const size_t data_offset = bytes.size();
  bytes.resize(data_offset + cloud.size() * kBytesPerPoint);
  char* out = bytes.data() + data_offset;
  for (size_t i = 0; i < cloud.size(); ++i) {
    const float point[4] = {cloud.points[i].x(), cloud.points[i].y(), cloud.points[i].z(),
                            cloud.intensities[i]};
    std::memcpy(out + i * kBytesPerPoint, point, kBytesPerPoint);
  }
  return bytes;
}

PointCloud decode_pcd(std::string_view bytes, const std::string& path) {
  // The point count is in the header; parse it, then require the exact header that
  // encode_pcd writes for that count.
  constexpr std::string_view kPointsKey = "\nPOINTS ";
  const size_t key = bytes.find(kPointsKey);
  if (key == std::string_view::npos) {
    throw MapError::in_file(path, "not a liloc keyframe PCD (no POINTS line)");
  }
  const char* first = bytes.data() + key + kPointsKey.size();
  size_t points = 0;
  const auto [end, error] = std::from_chars(first, bytes.data() + bytes.size(), points);
  if (error != std::errc() || end == first) {
    throw MapError::in_file(path, "malformed POINTS line");
  }
  if (points > bytes.size() / kBytesPerPoint) {
    throw MapError::in_file(path, "truncated: " + std::to_string(bytes.size()) + " bytes for " +
                                      std::to_string(points) + " points");
  }
  const std::string header = header_for(points);
  if (bytes.substr(0, header.size()) != header) {
    throw MapError::in_file(path,
                            "unexpected PCD header (expected binary x y z intensity float32)");
  }
  const size_t expected_bytes = header.size() + points * kBytesPerPoint;
  if (bytes.size() < expected_bytes) {
    throw MapError::in_file(path, "truncated: " + std::to_string(bytes.size()) + " bytes, " +
                                      std::to_string(points) + " points need " +
                                      std::to_string(expected_bytes));
  }
  if (bytes.size() > expected_bytes) {
    throw MapError::in_file(
        path, std::to_string(bytes.size() - expected_bytes) + " bytes after the last point");
  }
  PointCloud cloud;
  cloud.points.resize(points);
  cloud.intensities.resize(points);
  const char* in = bytes.data() + header.size();
  for (size_t i = 0; i < points; ++i) {
    float point[4];
    std::memcpy(point, in + i * kBytesPerPoint, kBytesPerPoint);
    cloud.points[i] = Eigen::Vector3f(point[0], point[1], point[2]);
    cloud.intensities[i] = point[3];
  }
  return cloud;
}

}  // namespace liloc::storage
