#include "descriptor/polar_descriptor.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

namespace liloc {
namespace {

constexpr double kTwoPi = 6.283185307179586;
// Dimensions the encoding (uint16) and any sane configuration allow.
constexpr int kMaxDimension = 4096;
constexpr char kMagic[4] = {'L', 'P', 'D', '1'};
constexpr size_t kHeaderBytes = 8;
constexpr size_t kCellBytes = 7;  // float32 height + 3 x int8 normal

void check_dimensions(int rings, int sectors, const char* what) {
  if (rings < 1 || sectors < 3 || rings > kMaxDimension || sectors > kMaxDimension) {
    throw std::invalid_argument(std::string(what) + ": rings must be within 1 .. " +
                                std::to_string(kMaxDimension) + " and sectors within 3 .. " +
                                std::to_string(kMaxDimension) + ", got " + std::to_string(rings) +
                                " x " + std::to_string(sectors));
  }
}

void check_consistent(const PolarDescriptor& d, const char* what) {
  check_dimensions(d.rings, d.sectors, what);
  const size_t cells = static_cast<size_t>(d.rings) * d.sectors;
  if (d.max_height_m.size() != cells || d.normals.size() != cells || d.occupied.size() != cells) {
    throw std::invalid_argument(std::string(what) + ": arrays do not hold rings x sectors cells");
  }
}

// The matrix Eq. 4's distance compares, column (sector) by column: per cell, the height above the
// descriptor's floor and the normal in the cell's polar frame (radial, tangential, up),
// where a column shift compares normals as a rotation of the sensor would; zero for
// empty cells. Each column's norm is kept, as it does not depend on the shift.
struct Columns {
  static constexpr int kFeatures = 4;  // height, normal x 3
  std::vector<float> features;         // [sector][ring][feature]
  std::vector<double> norms;           // per sector
};

// The floor: the 5th percentile of the occupied cells' heights, the ground for a sensor
// on a vehicle (Scan Context adds a fixed sensor height instead; an estimate also holds
// for other mountings and body frames). Heights above it make ground cells and empty
// cells alike small, so that the sparse rings' flickering ground hits weigh little.
float floor_height(const PolarDescriptor& d) {
  std::vector<float> heights;
  for (size_t k = 0; k < d.occupied.size(); ++k) {
    if (d.occupied[k]) {
      heights.push_back(d.max_height_m[k]);
    }
  }
  if (heights.empty()) {
    return 0.0f;
  }
  const auto nth = heights.begin() + heights.size() / 20;
  std::nth_element(heights.begin(), nth, heights.end());
  return *nth;
}

Eigen::Map<const Eigen::VectorXf> column(const Columns& c, int sector, int rings) {
  const size_t size = static_cast<size_t>(rings) * Columns::kFeatures;
  return Eigen::Map<const Eigen::VectorXf>(&c.features[sector * size], size);
}

Columns columns(const PolarDescriptor& d) {
  Columns c;
  c.features.assign(static_cast<size_t>(d.sectors) * d.rings * Columns::kFeatures, 0.0f);
  c.norms.assign(d.sectors, 0.0);
  const float floor = floor_height(d);
  for (int j = 0; j < d.sectors; ++j) {
    const double theta = (j + 0.5) * kTwoPi / d.sectors;
    const float cos_t = static_cast<float>(std::cos(theta));
    const float sin_t = static_cast<float>(std::sin(theta));
    for (int i = 0; i < d.rings; ++i) {
      const size_t k = static_cast<size_t>(i) * d.sectors + j;
      if (!d.occupied[k]) {
        continue;
      }
      const Eigen::Vector3f& n = d.normals[k];
      float* f = &c.features[(static_cast<size_t>(j) * d.rings + i) * Columns::kFeatures];
      f[0] = std::max(0.0f, d.max_height_m[k] - floor);
      f[1] = cos_t * n.x() + sin_t * n.y();
      f[2] = -sin_t * n.x() + cos_t * n.y();
      f[3] = n.z();
    }
    // The same (vectorized, float) dot product as between columns in compare(), so that
    // equal columns have a cosine of 1 to rounding.
    const float squared = column(c, j, d.rings).dot(column(c, j, d.rings));
    c.norms[j] = std::sqrt(static_cast<double>(squared));
  }
  return c;
}

void put_u16(std::vector<uint8_t>& out, int v) {
  out.push_back(static_cast<uint8_t>(v & 0xff));
  out.push_back(static_cast<uint8_t>((v >> 8) & 0xff));
}

int get_u16(const uint8_t* p) { return p[0] | (p[1] << 8); }

void put_f32(std::vector<uint8_t>& out, float v) {
  uint32_t bits;
  std::memcpy(&bits, &v, sizeof bits);
  for (int b = 0; b < 4; ++b) {
    out.push_back(static_cast<uint8_t>((bits >> (8 * b)) & 0xff));
  }
}

float get_f32(const uint8_t* p) {
  const uint32_t bits = static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) |
                        (static_cast<uint32_t>(p[2]) << 16) | (static_cast<uint32_t>(p[3]) << 24);
  float v;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

int8_t quantize(float x) {
  return static_cast<int8_t>(std::lround(std::clamp(x, -1.0f, 1.0f) * 127.0f));
}

}  // namespace

void PolarDescriptorConfig::validate() const {
  check_dimensions(rings, sectors, "polar descriptor");
  if (!(max_range_m > 0.0)) {
    throw std::invalid_argument("max_range_m must be positive");
  }
}

PolarDescriptor make_polar_descriptor(const PointCloud& cloud_body,
                                      const PolarDescriptorConfig& config) {
  config.validate();
  PolarDescriptor d;
  d.rings = config.rings;
  d.sectors = config.sectors;
  const size_t cells = static_cast<size_t>(d.rings) * d.sectors;
  d.max_height_m.assign(cells, 0.0f);
  d.normals.assign(cells, Eigen::Vector3f::Zero());
  d.occupied.assign(cells, 0);

  const double ring_m = config.max_range_m / d.rings;
  const double sector_rad = kTwoPi / d.sectors;
  for (const Eigen::Vector3f& p : cloud_body.points) {
    if (!p.allFinite()) {
      continue;
    }
    const double rho = std::hypot(static_cast<double>(p.x()), static_cast<double>(p.y()));
    if (rho >= config.max_range_m) {
      continue;
    }
    double theta = std::atan2(static_cast<double>(p.y()), static_cast<double>(p.x()));
    if (theta < 0.0) {
      theta += kTwoPi;
    }
    const int i = std::min(static_cast<int>(rho / ring_m), d.rings - 1);
    // theta just below 2 pi can round to sector N_a.
    const int j = std::min(static_cast<int>(theta / sector_rad), d.sectors - 1);
    const size_t k = static_cast<size_t>(i) * d.sectors + j;
    if (!d.occupied[k] || p.z() > d.max_height_m[k]) {
      d.max_height_m[k] = p.z();
      d.occupied[k] = 1;
    }
  }

  // Slope of the max-height surface along one axis of a cell, from its neighbours at
  // `step` metres (central where both exist, one-sided next to an empty cell).
  const auto slope = [&](size_t k, size_t lower, bool has_lower, size_t upper, bool has_upper,
                         double step) {
    const bool lo = has_lower && d.occupied[lower];
    const bool up = has_upper && d.occupied[upper];
    if (lo && up) {
      return (d.max_height_m[upper] - d.max_height_m[lower]) / (2.0 * step);
    }
    if (up) {
      return (d.max_height_m[upper] - d.max_height_m[k]) / step;
    }
    if (lo) {
      return (d.max_height_m[k] - d.max_height_m[lower]) / step;
    }
    return 0.0;
  };
  for (int i = 0; i < d.rings; ++i) {
    const double arc_m = (i + 0.5) * ring_m * sector_rad;  // between sector centres
    for (int j = 0; j < d.sectors; ++j) {
      const size_t k = static_cast<size_t>(i) * d.sectors + j;
      if (!d.occupied[k]) {
        continue;
      }
      const size_t row = static_cast<size_t>(i) * d.sectors;
      const double g_radial =
          slope(k, k - d.sectors, i > 0, k + d.sectors, i + 1 < d.rings, ring_m);
      const double g_tangential = slope(k, row + (j + d.sectors - 1) % d.sectors, true,
                                        row + (j + 1) % d.sectors, true, arc_m);
      const Eigen::Vector3d n_local = Eigen::Vector3d(-g_radial, -g_tangential, 1.0).normalized();
      const double theta = (j + 0.5) * sector_rad;
      const double c = std::cos(theta), s = std::sin(theta);
      d.normals[k] = Eigen::Vector3d(c * n_local.x() - s * n_local.y(),
                                     s * n_local.x() + c * n_local.y(), n_local.z())
                         .cast<float>();
    }
  }
  return d;
}

PolarDescriptor make_level_polar_descriptor(const PointCloud& cloud_body,
                                            const Eigen::Matrix3d& R_world_body,
                                            const PolarDescriptorConfig& config) {
  // R_level = Rz(-yaw) R_world_body: for R = Rz(yaw) Ry(pitch) Rx(roll), Ry(pitch) Rx(roll).
  const double yaw = std::atan2(R_world_body(1, 0), R_world_body(0, 0));
  const Eigen::Matrix3f R_level =
      (Eigen::AngleAxisd(-yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * R_world_body)
          .cast<float>();
  PointCloud level;
  level.points.reserve(cloud_body.size());
  for (const Eigen::Vector3f& p : cloud_body.points) {
    level.points.push_back(R_level * p);
  }
  return make_polar_descriptor(level, config);
}

DescriptorMatch compare(const PolarDescriptor& query, const PolarDescriptor& candidate) {
  check_consistent(query, "query descriptor");
  check_consistent(candidate, "candidate descriptor");
  if (query.rings != candidate.rings || query.sectors != candidate.sectors) {
    throw std::invalid_argument("descriptors differ in size: " + std::to_string(query.rings) + "x" +
                                std::to_string(query.sectors) + " vs " +
                                std::to_string(candidate.rings) + "x" +
                                std::to_string(candidate.sectors));
  }
  const int rings = query.rings;
  const int sectors = query.sectors;
  const Columns q = columns(query);
  const Columns c = columns(candidate);
  DescriptorMatch best;
  best.distance = std::numeric_limits<double>::infinity();
  // Shifts in the order 0, 1, -1, 2, -2, ... (every shift in (-N/2, N/2] once) and a strict
  // improvement rule: ties go to the smallest rotation.
  for (int n = 0; n < sectors; ++n) {
    const int shift = (n % 2 == 1) ? (n + 1) / 2 : -(n / 2);
    const int offset = (shift % sectors + sectors) % sectors;
    double similarity = 0.0;
    int columns_compared = 0;
    for (int j = 0; j < sectors; ++j) {
      const int jc = (j + offset) % sectors;
      if (q.norms[j] == 0.0 || c.norms[jc] == 0.0) {
        continue;
      }
      const double dot = column(q, j, rings).dot(column(c, jc, rings));
      // Clamped: rounding can take the cosine of equal columns just above 1.
      similarity += std::clamp(dot / (q.norms[j] * c.norms[jc]), 0.0, 1.0);
      ++columns_compared;
    }
    const double distance = columns_compared > 0 ? 1.0 - similarity / columns_compared : 1.0;
    if (distance < best.distance) {
      best.distance = distance;
      best.sector_shift = shift;
    }
  }
  best.yaw_rad = best.sector_shift * kTwoPi / sectors;
  return best;
}

std::vector<float> ring_key(const PolarDescriptor& descriptor) {
  check_consistent(descriptor, "descriptor");
  std::vector<float> key(descriptor.rings, 0.0f);
  for (int i = 0; i < descriptor.rings; ++i) {
    int occupied = 0;
    for (int j = 0; j < descriptor.sectors; ++j) {
      occupied += descriptor.occupied[static_cast<size_t>(i) * descriptor.sectors + j] != 0;
    }
    key[i] = static_cast<float>(occupied) / descriptor.sectors;
  }
  return key;
}

std::vector<uint8_t> encode(const PolarDescriptor& descriptor) {
  check_consistent(descriptor, "descriptor to encode");
  const size_t cells = static_cast<size_t>(descriptor.rings) * descriptor.sectors;
  std::vector<uint8_t> out(kMagic, kMagic + 4);
  put_u16(out, descriptor.rings);
  put_u16(out, descriptor.sectors);
  const size_t bits_at = out.size();
  out.resize(bits_at + (cells + 7) / 8, 0);
  for (size_t k = 0; k < cells; ++k) {
    if (descriptor.occupied[k]) {
      out[bits_at + k / 8] |= static_cast<uint8_t>(1u << (k % 8));
    }
  }
  for (size_t k = 0; k < cells; ++k) {
    if (!descriptor.occupied[k]) {
      continue;
    }
    put_f32(out, descriptor.max_height_m[k]);
    for (int axis = 0; axis < 3; ++axis) {
      out.push_back(static_cast<uint8_t>(quantize(descriptor.normals[k][axis])));
    }
  }
  return out;
}

PolarDescriptor decode_descriptor(const uint8_t* data, size_t size) {
  const auto fail = [](const std::string& what) {
    throw std::invalid_argument("polar descriptor bytes: " + what);
  };
  if (size < kHeaderBytes) {
    fail("truncated header (" + std::to_string(size) + " of " + std::to_string(kHeaderBytes) +
         " bytes)");
  }
  if (std::memcmp(data, kMagic, 4) != 0) {
    fail("wrong magic (not \"LPD1\")");
  }
  PolarDescriptor d;
  d.rings = get_u16(data + 4);
  d.sectors = get_u16(data + 6);
  try {
    check_dimensions(d.rings, d.sectors, "header");
  } catch (const std::invalid_argument& e) {
    fail(e.what());
  }
  const size_t cells = static_cast<size_t>(d.rings) * d.sectors;
  const size_t bit_bytes = (cells + 7) / 8;
  if (size < kHeaderBytes + bit_bytes) {
    fail("truncated occupancy bits (" + std::to_string(size - kHeaderBytes) + " of " +
         std::to_string(bit_bytes) + " bytes)");
  }
  const uint8_t* bits = data + kHeaderBytes;
  if (cells % 8 != 0 && (bits[bit_bytes - 1] >> (cells % 8)) != 0) {
    fail("padding bits after the last cell are set");
  }
  d.max_height_m.assign(cells, 0.0f);
  d.normals.assign(cells, Eigen::Vector3f::Zero());
  d.occupied.assign(cells, 0);
  size_t occupied = 0;
  for (size_t k = 0; k < cells; ++k) {
    d.occupied[k] = (bits[k / 8] >> (k % 8)) & 1u;
    occupied += d.occupied[k];
  }
  const size_t expected = kHeaderBytes + bit_bytes + occupied * kCellBytes;
  if (size < expected) {
    fail("truncated cells (" + std::to_string(size) + " bytes, " + std::to_string(occupied) +
         " occupied cells need " + std::to_string(expected) + ")");
  }
  if (size > expected) {
    fail(std::to_string(size - expected) + " trailing bytes after " + std::to_string(occupied) +
         " occupied cells");
  }
  const uint8_t* p = bits + bit_bytes;
  for (size_t k = 0; k < cells; ++k) {
    if (!d.occupied[k]) {
      continue;
    }
    const float h = get_f32(p);
    if (!std::isfinite(h)) {
      fail("height of cell " + std::to_string(k) + " is not finite");
    }
    const Eigen::Vector3f n(static_cast<int8_t>(p[4]), static_cast<int8_t>(p[5]),
                            static_cast<int8_t>(p[6]));
    if (n.isZero()) {
      fail("normal of cell " + std::to_string(k) + " is zero");
    }
    d.max_height_m[k] = h;
    d.normals[k] = n.normalized();
    p += kCellBytes;
  }
  return d;
}

}  // namespace liloc
