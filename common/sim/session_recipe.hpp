#pragma once
// The one recipe for a simulated multi-session dataset, used by liloc_sim and the
// benchmarks alike: the world of session A; the same world a day later (day changes
// seeded by world seed + 1) for the sessions that come back on another day; and each
// session's route, random seed and start time from its name alone.

#include <cstdint>
#include <string>

#include "sim/session_planner.hpp"
#include "sim/simulation_config.hpp"
#include "sim/world.hpp"
#include "sim/world_generator.hpp"

namespace liloc::sim {

struct SimulatedSession {
  SessionPlan plan;
  const World* world = nullptr;  // the world of the session's day (owned by SimulatedSessions)
  uint64_t seed = 0;             // hash of the world seed and the session's letter
  int64_t start_utime = 0;       // A at config.start_utime, B, C, D days_between_sessions apart
};

class SimulatedSessions {
 public:
  explicit SimulatedSessions(const SimulationConfig& config);
  SimulatedSessions(const SimulatedSessions&) = delete;
  SimulatedSessions& operator=(const SimulatedSessions&) = delete;

  // Throws std::invalid_argument for a name other than A, B, C or D.
  SimulatedSession session(const std::string& name) const;

  const SimulationConfig& config() const { return config_; }
  const GeneratedWorld& base() const { return base_; }
  const DayChangeReport& day_changes() const { return changes_; }

 private:
  SimulationConfig config_;
  GeneratedWorld base_;
  World changed_;
  DayChangeReport changes_;
};

// Scales every session's route length (short tests and demos).
void scale_session_lengths(SessionPlanConfig& sessions, double scale);

}  // namespace liloc::sim
