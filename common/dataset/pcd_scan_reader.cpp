#include "dataset/pcd_scan_reader.hpp"

#include <pcl/PCLPointCloud2.h>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include "dataset/dataset_error.hpp"

namespace liloc::dataset {
namespace {

// Times of at least this many seconds are since the epoch (1e6 s is 11.6 days, longer
// than any sweep); smaller ones are offsets within the sweep.
constexpr double kAbsoluteTimeMin_s = 1e6;
// Float times of at least this value can only be nanoseconds since the epoch.
constexpr double kNanosecondTimeMin = 1e15;

std::vector<std::string> tokens_of(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> tokens;
  for (std::string token; in >> token;) {
    tokens.push_back(token);
  }
  return tokens;
}

// PCL accepts unknown header keywords and short or non-numeric data lines silently (it
// fills zeros), so the text parts are checked here first, with line numbers.
struct PcdTextLayout {
  int64_t last_header_line = 0;  // the DATA line
  size_t values_per_point = 0;   // the sum of COUNT
  bool ascii = false;
};

PcdTextLayout check_pcd_header(const std::string& path) {
  static const std::set<std::string> kKeywords = {"VERSION", "FIELDS", "SIZE",   "TYPE",
                                                  "COUNT",   "WIDTH",  "HEIGHT", "VIEWPOINT",
                                                  "POINTS",  "DATA"};
  std::ifstream in(path);
  PcdTextLayout layout;
  std::set<std::string> seen;
  size_t field_count = 0;
  std::string line;
  int64_t line_number = 0;
  while (seen.count("DATA") == 0 && std::getline(in, line)) {
    ++line_number;
    const std::vector<std::string> tokens = tokens_of(line);
    if (tokens.empty() || tokens[0][0] == '#') {
      continue;
    }
    if (kKeywords.count(tokens[0]) == 0) {
      throw DatasetError::at_line(path, line_number,
                                  "unknown PCD header keyword '" + tokens[0] + "'");
    }
    if (tokens.size() < 2) {
      throw DatasetError::at_line(path, line_number, tokens[0] + " has no value");
    }
    seen.insert(tokens[0]);
    const size_t entries = tokens.size() - 1;
    if (tokens[0] == "FIELDS") {
      field_count = entries;
      layout.values_per_point = entries;  // COUNT defaults to 1 per field
    } else if (tokens[0] == "SIZE" || tokens[0] == "TYPE" || tokens[0] == "COUNT") {
      if (entries != field_count) {
        throw DatasetError::at_line(path, line_number,
                                    tokens[0] + " has " + std::to_string(entries) +
                                        " entries for " + std::to_string(field_count) + " fields");
      }
      if (tokens[0] == "COUNT") {
        layout.values_per_point = 0;
        for (size_t i = 1; i < tokens.size(); ++i) {
          layout.values_per_point +=
              static_cast<size_t>(std::max(1L, std::atol(tokens[i].c_str())));
        }
      }
    } else if (tokens[0] == "DATA") {
      layout.ascii = tokens[1] == "ascii";
    }
  }
  if (seen.count("DATA") == 0) {
    throw DatasetError::at_line(path, line_number, "PCD header ends without a DATA line");
  }
  for (const char* required : {"FIELDS", "SIZE", "TYPE", "WIDTH", "POINTS"}) {
    if (seen.count(required) == 0) {
      throw DatasetError::in_file(path, std::string("PCD header has no ") + required + " line");
    }
  }
  layout.last_header_line = line_number;
  return layout;
}

void check_ascii_data(const std::string& path, const PcdTextLayout& layout, uint64_t points) {
  std::ifstream in(path);
  std::string line;
  int64_t line_number = 0;
  while (line_number < layout.last_header_line && std::getline(in, line)) {
    ++line_number;
  }
  uint64_t points_read = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const std::vector<std::string> tokens = tokens_of(line);
    if (tokens.empty()) {
      continue;
    }
    if (points_read == points) {
      throw DatasetError::at_line(
          path, line_number,
          "more data lines than the " + std::to_string(points) + " points the header declares");
    }
    if (tokens.size() != layout.values_per_point) {
      throw DatasetError::at_line(path, line_number,
                                  "expected " + std::to_string(layout.values_per_point) +
                                      " values, found " + std::to_string(tokens.size()));
    }
    for (const std::string& token : tokens) {
      char* end = nullptr;
      std::strtod(token.c_str(), &end);
      if (*end != '\0') {
        throw DatasetError::at_line(path, line_number, "'" + token + "' is not a number");
      }
    }
    ++points_read;
  }
  if (points_read != points) {
    throw DatasetError::at_line(path, line_number + 1,
                                "truncated: the header declares " + std::to_string(points) +
                                    " points, the data has " + std::to_string(points_read));
  }
}

const pcl::PCLPointField* find_field(const pcl::PCLPointCloud2& cloud,
                                     std::initializer_list<const char*> names) {
  for (const char* name : names) {
    for (const pcl::PCLPointField& f : cloud.fields) {
      if (f.name == name) {
        return &f;
      }
    }
  }
  return nullptr;
}

template <class T>
double load(const uint8_t* p) {
  T value;
  std::memcpy(&value, p, sizeof(T));
  return static_cast<double>(value);
}

double value_at(const pcl::PCLPointCloud2& cloud, const pcl::PCLPointField& field, size_t i) {
  const uint8_t* p = cloud.data.data() + i * cloud.point_step + field.offset;
  using F = pcl::PCLPointField;
  switch (field.datatype) {
    case F::INT8:
      return load<int8_t>(p);
    case F::UINT8:
      return load<uint8_t>(p);
    case F::INT16:
      return load<int16_t>(p);
    case F::UINT16:
      return load<uint16_t>(p);
    case F::INT32:
      return load<int32_t>(p);
    case F::UINT32:
      return load<uint32_t>(p);
    case F::INT64:
      return load<int64_t>(p);
    case F::UINT64:
      return load<uint64_t>(p);
    case F::FLOAT32:
      return load<float>(p);
    case F::FLOAT64:
      return load<double>(p);
    default:
      return std::numeric_limits<double>::quiet_NaN();
  }
}

bool is_integer_type(uint8_t datatype) {
  using F = pcl::PCLPointField;
  return datatype != F::FLOAT32 && datatype != F::FLOAT64;
}

}  // namespace

PcdScan read_pcd_scan(const std::string& path, int64_t file_utime_us, float nominal_scan_period_s) {
  if (!std::ifstream(path)) {
    throw DatasetError::in_file(path, "cannot open");
  }
  pcl::PCDReader reader;
  pcl::PCLPointCloud2 header;
  Eigen::Vector4f origin;
  Eigen::Quaternionf orientation;
  int version = 0;
  int data_type = 0;
  unsigned int data_idx = 0;
  const PcdTextLayout layout = check_pcd_header(path);
  if (reader.readHeader(path, header, origin, orientation, version, data_type, data_idx) < 0) {
    throw DatasetError::in_file(path, "malformed PCD header");
  }
  const uint64_t points = uint64_t{header.width} * header.height;
  if (layout.ascii) {
    check_ascii_data(path, layout, points);
  }
  const uint64_t size = std::filesystem::file_size(path);
  if (data_type == 1) {
    const uint64_t end = data_idx + points * header.point_step;
    if (size < end) {
      throw DatasetError::at_byte(path, size,
                                  "truncated: the header declares " + std::to_string(points) +
                                      " points of " + std::to_string(header.point_step) +
                                      " bytes from byte " + std::to_string(data_idx) +
                                      ", so the data ends at byte " + std::to_string(end));
    }
  } else if (data_type == 2) {
    uint32_t compressed_bytes = 0;
    std::ifstream in(path, std::ios::binary);
    in.seekg(data_idx);
    if (!in.read(reinterpret_cast<char*>(&compressed_bytes), sizeof(compressed_bytes)) ||
        data_idx + 8 + uint64_t{compressed_bytes} > size) {
      throw DatasetError::at_byte(path, size, "truncated binary_compressed data");
    }
  }
  pcl::PCLPointCloud2 cloud;
  if (reader.read(path, cloud) < 0 || uint64_t{cloud.width} * cloud.height != points) {
    throw DatasetError::in_file(path, "PCL could not read the point data");
  }

  const pcl::PCLPointField* x = find_field(cloud, {"x"});
  const pcl::PCLPointField* y = find_field(cloud, {"y"});
  const pcl::PCLPointField* z = find_field(cloud, {"z"});
  if (x == nullptr || y == nullptr || z == nullptr) {
    throw DatasetError::in_file(path, "no x, y, z fields");
  }
  const pcl::PCLPointField* intensity = find_field(cloud, {"intensity"});
  const pcl::PCLPointField* ring = find_field(cloud, {"ring"});
  const pcl::PCLPointField* time = find_field(cloud, {"time", "t", "timestamp"});

  PcdScan out;
  std::vector<double> times_s;
  double time_scale = 1.0;
  if (time != nullptr) {
    double max_abs = 0.0;
    for (size_t i = 0; i < points; ++i) {
      const double t = value_at(cloud, *time, i);
      if (std::isfinite(t)) {
        max_abs = std::max(max_abs, std::abs(t));
      }
    }
    time_scale = is_integer_type(time->datatype) || max_abs >= kNanosecondTimeMin ? 1e-9 : 1.0;
  }
  out.scan.points.reserve(points);
  times_s.reserve(points);
  for (size_t i = 0; i < points; ++i) {
    LidarPoint p;
    p.position_m = Eigen::Vector3f(static_cast<float>(value_at(cloud, *x, i)),
                                   static_cast<float>(value_at(cloud, *y, i)),
                                   static_cast<float>(value_at(cloud, *z, i)));
    p.intensity = intensity != nullptr ? static_cast<float>(value_at(cloud, *intensity, i)) : 0.0f;
    const double t = time != nullptr ? value_at(cloud, *time, i) * time_scale : 0.0;
    if (!p.position_m.allFinite() || !std::isfinite(p.intensity) || !std::isfinite(t)) {
      ++out.dropped_non_finite_points;
      continue;
    }
    if (ring != nullptr) {
      const double r = value_at(cloud, *ring, i);
      if (!(r >= 0 && r <= 255)) {
        throw DatasetError::in_file(path, "point " + std::to_string(i) + ": ring " +
                                              std::to_string(r) + " is not in 0-255");
      }
      p.ring = static_cast<uint8_t>(std::lround(r));
    }
    out.scan.points.push_back(p);
    times_s.push_back(t);
  }

  double start_s = 0.0;  // relative to the file name's time
  if (!times_s.empty()) {
    const auto [min_t, max_t] = std::minmax_element(times_s.begin(), times_s.end());
    if (*max_t >= kAbsoluteTimeMin_s) {
      start_s = *min_t;
      out.scan.utime_us = static_cast<int64_t>(std::llround(start_s * 1e6));
    } else {
      start_s = std::min(*min_t, 0.0);
      out.scan.utime_us = file_utime_us + static_cast<int64_t>(std::llround(start_s * 1e6));
    }
  } else {
    out.scan.utime_us = file_utime_us;
  }
  float span_s = 0.0f;
  for (size_t i = 0; i < times_s.size(); ++i) {
    out.scan.points[i].time_offset_s = static_cast<float>(times_s[i] - start_s);
    span_s = std::max(span_s, out.scan.points[i].time_offset_s);
  }
  out.scan.scan_period_s = std::max(nominal_scan_period_s, span_s);
  return out;
}

}  // namespace liloc::dataset
