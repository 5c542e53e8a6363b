#pragma once
// Routes of the multi-session dataset over one world:
//   A  central session: a long tour of the mapped region with loops, back to its start;
//   B  starts in A's region, drives into the unmapped region and comes back
//      (a localizer must switch RLM -> ILM -> RLM);
//   C  another day (the world is changed): a tour of the mapped region;
//   D  starts mid-street at a place and heading the robot is not told.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "sim/world.hpp"

namespace liloc::sim {

struct SessionPlanConfig {
  double a_length_m = 1500.0;
  double b_inside_m = 150.0;     // in the mapped region before leaving and after returning
  double b_excursion_m = 350.0;  // in the unmapped region
  double c_length_m = 1000.0;
  double d_length_m = 600.0;

  template <class V>
  void visit_fields(V& v) {
    v("a_length_m", a_length_m);
    v("b_inside_m", b_inside_m);
    v("b_excursion_m", b_excursion_m);
    v("c_length_m", c_length_m);
    v("d_length_m", d_length_m);
  }
  void validate() const;
};

struct SessionPlan {
  std::string name;  // "A", "B", "C", "D"
  std::vector<Eigen::Vector2d> waypoints;
  int day = 0;                     // C runs on a changed world (day 1)
  bool initial_pose_known = true;  // false for D
  std::string description;
};

// Throws std::invalid_argument for an unknown session name, or if the world has no
// unmapped roads for B.
SessionPlan plan_session(const std::string& name, const World& world, double mapped_max_x_m,
                         const SessionPlanConfig& config, uint64_t seed);

}  // namespace liloc::sim
