#pragma once
// Keyframe clouds as binary PCD (PCL's format, v0.7): fields x y z intensity, float32,
// little-endian, unorganized (HEIGHT 1). PCL, CloudCompare and pcl_viewer open these
// files. Storage writes and reads them itself instead of through PCL: a save encodes a
// cloud into memory once to checksum it, write it and fsync it, and a load checks the
// checksum of exactly the bytes it decodes, without a second pass over the file.

#include <string>
#include <string_view>

#include "pointcloud/point_cloud.hpp"

namespace liloc::storage {

std::string encode_pcd(const PointCloud& cloud);

// Decodes what encode_pcd writes (and only that layout). Throws MapError naming `path`
// on another header, or "truncated" / trailing bytes if the data does not match POINTS.
PointCloud decode_pcd(std::string_view bytes, const std::string& path);

}  // namespace liloc::storage
