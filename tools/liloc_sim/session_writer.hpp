#pragma once
// Writes one simulated session to disk: the LCM log of its sensor stream, its ground
// truth (TUM) and a manifest describing how it was made.

#include <string>

#include "sim/session_recipe.hpp"
#include "sim/session_simulator.hpp"
#include "sim/simulation_config.hpp"

namespace liloc::tools {

struct SessionOutput {
  std::string directory;
  std::string log_path;
  std::string ground_truth_path;
  std::string manifest_path;
  sim::SessionStats stats;
  double length_m = 0.0;
  double duration_s = 0.0;
  double wall_time_s = 0.0;
  size_t log_bytes = 0;
};

// Simulates the session with the given LiDAR and writes it under `directory`. Prints
// progress to stderr when `show_progress`.
SessionOutput write_session(const sim::SimulatedSession& session,
                            const sim::SimulationConfig& config, const std::string& lidar_model,
                            const std::string& directory, int threads, bool show_progress);

}  // namespace liloc::tools
