#pragma once
// TUM trajectory files: one pose per line, "time_s tx ty tz qx qy qz qw", '#' comments.

#include <string>

#include "math/trajectory.hpp"

namespace liloc {

// Throws std::runtime_error naming the file and line of the first malformed entry
// (wrong field count, non-numeric or non-finite value, quaternion far from unit norm,
// repeated timestamp).
Trajectory read_tum(const std::string& path);

// Writes with microsecond time resolution and 1e-9 pose resolution; throws naming the
// file if it cannot be written.
void write_tum(const std::string& path, const Trajectory& trajectory);

}  // namespace liloc
