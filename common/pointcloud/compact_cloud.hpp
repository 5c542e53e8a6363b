#pragma once
// A point cloud quantized to 7 bytes a point instead of PointCloud's 16: int16 coordinates
// in steps of resolution_m and uint8 intensities. Submap replies are kept in this form on
// disk and in the server's memory and travel in it (compact_cloud_t), so that serving a
// submap copies bytes instead of converting every point.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "pointcloud/point_cloud.hpp"

namespace liloc {

struct CompactCloud {
  float resolution_m = 0.01f;    // a coordinate is steps * resolution_m
  float intensity_scale = 1.0f;  // an intensity is byte * intensity_scale
  std::vector<int16_t> x, y, z;
  std::vector<uint8_t> intensity;

  size_t size() const { return x.size(); }
  bool empty() const { return x.empty(); }
};

// Quantizes to `resolution_m` (error at most half a step), with coarser steps only if a
// coordinate would not fit in int16, and intensities to 1/255 of the largest one.
// Non-finite intensities become 0; a non-finite point throws std::invalid_argument.
CompactCloud quantize(const PointCloud& cloud, float resolution_m = 0.01f);

// Points [begin, end) in metres.
PointCloud dequantize(const CompactCloud& cloud, size_t begin, size_t end);
inline PointCloud dequantize(const CompactCloud& cloud) {
  return dequantize(cloud, 0, cloud.size());
}

// Points [begin, end), with the same steps.
CompactCloud slice(const CompactCloud& cloud, size_t begin, size_t end);

// Throws std::invalid_argument, naming the problem, unless the steps and the intensity
// scale are positive and finite and the four arrays have one size.
void check_compact_cloud(const CompactCloud& cloud);

}  // namespace liloc
