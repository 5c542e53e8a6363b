#include "sim/session_recipe.hpp"

#include <stdexcept>

#include "sim/random.hpp"

namespace liloc::sim {

SimulatedSessions::SimulatedSessions(const SimulationConfig& config)
    : config_(config), base_(generate_world(config.world)), changed_(base_.world) {
  changes_ = apply_day_changes(changed_, config_.world.seed + 1, config_.changes);
}

SimulatedSession SimulatedSessions::session(const std::string& name) const {
  if (name.size() != 1 || name[0] < 'A' || name[0] > 'D') {
    throw std::invalid_argument("unknown session '" + name + "' (A, B, C or D)");
  }
  SimulatedSession s;
  s.seed = hash_combine(static_cast<uint64_t>(config_.world.seed), static_cast<uint64_t>(name[0]));
  s.plan = plan_session(name, base_.world, base_.mapped_max_x_m, config_.sessions, s.seed);
  s.world = s.plan.day == 0 ? &base_.world : &changed_;
  s.start_utime =
      config_.start_utime + (name[0] - 'A') * config_.days_between_sessions * 86400LL * 1000000LL;
  return s;
}

void scale_session_lengths(SessionPlanConfig& sessions, double scale) {
  if (!(scale > 0.0)) {
    throw std::invalid_argument("the length scale must be positive");
  }
  sessions.a_length_m *= scale;
  sessions.b_inside_m *= scale;
  sessions.b_excursion_m *= scale;
  sessions.c_length_m *= scale;
  sessions.d_length_m *= scale;
}

}  // namespace liloc::sim
