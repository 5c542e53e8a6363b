#pragma once
// Making map directories: from a recorded drive (liloc_map build), from scans with known
// poses (build-from-poses) and from one global point cloud (build-from-pcd).

#include <string>

#include "mapping/central_session_builder.hpp"
#include "system/system_config.hpp"

namespace liloc {

int build_map(int argc, const char* const* argv);
int build_map_from_poses(int argc, const char* const* argv);
int build_map_from_pcd(int argc, const char* const* argv);

// Reference poses at most this far apart are interpolated (a 1 Hz pose file still is):
// build --poses, and build-from-poses' --max-gap-s default.
constexpr double kReferencePoseMaxGapS = 1.5;

// Throws std::invalid_argument if the directory already holds a map: never overwritten.
void require_new_map_directory(const std::string& directory);

// A builder with the system's settings (its loop closure uses the system's descriptor, its
// submaps the system's rule) for `session`; loops closed if close_loops and the config
// says so.
CentralSessionBuilder central_session_builder(const SystemConfig& config,
                                              const std::string& session, bool close_loops);

// Optimizes, cuts into submaps, computes the keyframe descriptors, saves version 1 and
// prints the summary.
MapData save_built_map(CentralSessionBuilder& builder, const SystemConfig& config,
                       const std::string& directory, const std::string& map_id,
                       CentralSessionReport* report);

void print_map_summary(const std::string& directory, const MapData& map,
                       const CentralSessionReport& report);

}  // namespace liloc
