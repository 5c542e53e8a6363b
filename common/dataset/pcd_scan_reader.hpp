#pragma once
// One LiDAR sweep from a PCD file (ASCII, binary or binary_compressed), through PCL.
// The only translation unit of the dataset module that includes PCL, in its own library
// (liloc_dataset_pcd), so that PCL's headers and libraries stay out of everything else.
//
// Fields: x y z (required, any numeric type), intensity (optional, else 0), ring
// (optional, else 0), and a per-point time named time, t or timestamp (optional, else
// every point at the sweep start). The time field is read as
//   - nanoseconds if its type is an integer (Ouster's uint32 t) or its values reach 1e15,
//   - seconds otherwise;
// values of at least 1e6 s are absolute (since the epoch), smaller ones are offsets from
// the time in the file name. The sweep starts at its earliest point (so offsets are >= 0
// even for drivers that stamp the sweep's end with negative offsets), or at the file
// name's time when there is no time field.

#include <cstdint>
#include <string>

#include "pointcloud/point_cloud.hpp"

namespace liloc::dataset {

struct PcdScan {
  LidarScan scan;
  int64_t dropped_non_finite_points = 0;  // a non-finite coordinate, intensity or time
};

// file_utime_us: the time taken from the file name. The sweep's period is the larger of
// nominal_scan_period_s and the span of its point times. Throws DatasetError naming the
// file (and the byte offset or line where it can be known) on a missing, truncated or
// malformed file, or if x, y or z is missing.
PcdScan read_pcd_scan(const std::string& path, int64_t file_utime_us, float nominal_scan_period_s);

}  // namespace liloc::dataset
