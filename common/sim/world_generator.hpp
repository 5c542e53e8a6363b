#pragma once
// Procedural worlds from a seed: an open campus (roads on a jittered grid through
// buildings, parking lots, parks and plazas, with terrain slopes, curbs and speed humps)
// and a long, feature-poor ring tunnel (degenerate along its axis).

#include <cstdint>
#include <stdexcept>
#include <string>

#include "sim/world.hpp"

namespace liloc::sim {

struct WorldConfig {
  std::string kind = "campus";  // "campus" or "corridor"
  int64_t seed = 1;
  // Campus.
  double size_x_m = 300.0;
  double size_y_m = 300.0;
  double margin_m = 60.0;           // open terrain with scattered trees around the campus
  double block_m = 67.5;            // road spacing
  double road_width_m = 10.0;       // curb to curb
  double lane_offset_m = 2.0;       // driving lane centre, right of the road centre
  double mapped_fraction_x = 0.67;  // session A stays west of this fraction of size_x
  double node_jitter_m = 5.0;
  double terrain_amplitude_m = 3.0;     // peak-to-peak of the rolling terrain
  double speed_hump_probability = 0.3;  // per road segment
  // Corridor (a rectangular ring tunnel).
  double corridor_length_m = 400.0;
  double corridor_spacing_m = 40.0;  // between the two long tunnels
  double corridor_width_m = 7.0;
  double corridor_height_m = 5.0;
  // Index.
  double grid_cell_m = 4.0;
  double ground_resolution_m = 1.0;

  template <class V>
  void visit_fields(V& v) {
    v("kind", kind);
    v("seed", seed);
    v("size_x_m", size_x_m);
    v("size_y_m", size_y_m);
    v("margin_m", margin_m);
    v("block_m", block_m);
    v("road_width_m", road_width_m);
    v("lane_offset_m", lane_offset_m);
    v("mapped_fraction_x", mapped_fraction_x);
    v("node_jitter_m", node_jitter_m);
    v("terrain_amplitude_m", terrain_amplitude_m);
    v("speed_hump_probability", speed_hump_probability);
    v("corridor_length_m", corridor_length_m);
    v("corridor_spacing_m", corridor_spacing_m);
    v("corridor_width_m", corridor_width_m);
    v("corridor_height_m", corridor_height_m);
    v("grid_cell_m", grid_cell_m);
    v("ground_resolution_m", ground_resolution_m);
  }
  void validate() const;
};

// What changes between the central session's day and a later one (session C).
struct DayChangeConfig {
  double movable_change_fraction = 0.25;  // of cars: each moved or removed
  int new_structures = 10;                // containers, kiosks, fences
  double foliage_scale_min = 0.8;         // crowns grow or are cut back
  double foliage_scale_max = 1.2;
  double foliage_density_min = 0.5;  // leaves fall or grow (hits per metre scale)
  double foliage_density_max = 1.5;
  double bush_removal_fraction = 0.1;

  template <class V>
  void visit_fields(V& v) {
    v("movable_change_fraction", movable_change_fraction);
    v("new_structures", new_structures);
    v("foliage_scale_min", foliage_scale_min);
    v("foliage_scale_max", foliage_scale_max);
    v("foliage_density_min", foliage_density_min);
    v("foliage_density_max", foliage_density_max);
    v("bush_removal_fraction", bush_removal_fraction);
  }
  void validate() const;
};

struct GeneratedWorld {
  World world;
  // Region of session A (the central session): x below this bound.
  double mapped_max_x_m;
};

GeneratedWorld generate_world(const WorldConfig& config);

// Summary of what apply_day_changes did.
struct DayChangeReport {
  int cars_total = 0;
  int cars_moved = 0;
  int cars_removed = 0;
  int structures_added = 0;
  int foliage_changed = 0;
  int bushes_removed = 0;
};

// Changes the world's objects as another day would (seeded): cars moved or gone, new
// structures, foliage grown, cut or thinned.
DayChangeReport apply_day_changes(World& world, int64_t seed, const DayChangeConfig& config);

}  // namespace liloc::sim
