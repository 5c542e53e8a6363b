#include "pointcloud/compact_cloud.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace liloc {

CompactCloud quantize(const PointCloud& cloud, float resolution_m) {
  constexpr float kMaxSteps = 32767.0f;  // int16
  float extent = 0.0f;
  float max_intensity = 0.0f;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (!cloud.points[i].allFinite()) {
      throw std::invalid_argument("compact cloud: point " + std::to_string(i) + " is not finite");
    }
    extent = std::max(extent, cloud.points[i].cwiseAbs().maxCoeff());
    if (std::isfinite(cloud.intensities[i])) {
      max_intensity = std::max(max_intensity, cloud.intensities[i]);
    }
  }
  CompactCloud out;
  // The extent must round inside int16: one step of margin.
  out.resolution_m = std::max(resolution_m, extent / (kMaxSteps - 1.0f));
  out.intensity_scale = max_intensity > 0.0f ? max_intensity / 255.0f : 1.0f;
  const size_t n = cloud.size();
  out.x.resize(n);
  out.y.resize(n);
  out.z.resize(n);
  out.intensity.resize(n);
  const float to_steps = 1.0f / out.resolution_m;
  const float to_byte = 1.0f / out.intensity_scale;
  // Round half away from zero, inline: std::lround is a library call per coordinate.
  const auto round = [](float v) { return static_cast<int32_t>(v >= 0.0f ? v + 0.5f : v - 0.5f); };
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f& p = cloud.points[i];
    out.x[i] = static_cast<int16_t>(round(p.x() * to_steps));
    out.y[i] = static_cast<int16_t>(round(p.y() * to_steps));
    out.z[i] = static_cast<int16_t>(round(p.z() * to_steps));
    // Clamped as a float: casting an out-of-range or NaN float to int is undefined.
    const float byte = cloud.intensities[i] * to_byte;
    out.intensity[i] = static_cast<uint8_t>(!(byte > 0.0f)   ? 0
                                            : byte >= 255.0f ? 255
                                                             : round(byte));
  }
  return out;
}

PointCloud dequantize(const CompactCloud& cloud, size_t begin, size_t end) {
  PointCloud out;
  out.reserve(end - begin);
  for (size_t i = begin; i < end; ++i) {
    out.push_back(Eigen::Vector3f(cloud.x[i], cloud.y[i], cloud.z[i]) * cloud.resolution_m,
                  cloud.intensity[i] * cloud.intensity_scale);
  }
  return out;
}

CompactCloud slice(const CompactCloud& cloud, size_t begin, size_t end) {
  CompactCloud out;
  out.resolution_m = cloud.resolution_m;
  out.intensity_scale = cloud.intensity_scale;
  out.x.assign(cloud.x.begin() + begin, cloud.x.begin() + end);
  out.y.assign(cloud.y.begin() + begin, cloud.y.begin() + end);
  out.z.assign(cloud.z.begin() + begin, cloud.z.begin() + end);
  out.intensity.assign(cloud.intensity.begin() + begin, cloud.intensity.begin() + end);
  return out;
}

void check_compact_cloud(const CompactCloud& cloud) {
  if (!(std::isfinite(cloud.resolution_m) && cloud.resolution_m > 0.0f) ||
      !(std::isfinite(cloud.intensity_scale) && cloud.intensity_scale > 0.0f)) {
    throw std::invalid_argument("compact cloud: resolution " + std::to_string(cloud.resolution_m) +
                                " m or intensity scale " + std::to_string(cloud.intensity_scale) +
                                " is not positive");
  }
  const size_t n = cloud.x.size();
  if (cloud.y.size() != n || cloud.z.size() != n || cloud.intensity.size() != n) {
    throw std::invalid_argument("compact cloud: arrays of " + std::to_string(n) + ", " +
                                std::to_string(cloud.y.size()) + ", " +
                                std::to_string(cloud.z.size()) + " and " +
                                std::to_string(cloud.intensity.size()) + " points");
  }
}

}  // namespace liloc
