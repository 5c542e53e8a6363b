#pragma once
// Visits the cells of a regular 2D grid that a ray crosses, in order along the ray
// (Amanatides & Woo, "A Fast Voxel Traversal Algorithm", 1987).

#include <algorithm>
#include <cmath>
#include <limits>

namespace liloc::sim {

struct Grid2d {
  double origin_x = 0.0;
  double origin_y = 0.0;
  double cell = 1.0;
  int nx = 0;
  int ny = 0;
};

// Calls visit(ix, iy, t_enter, t_exit) for each cell the ray origin + t * dir crosses for
// t in [0, t_max]; stops when visit returns false. dir need not be normalized; t is in
// units of dir.
template <class Visit>
void traverse_grid(const Grid2d& g, double ox, double oy, double dx, double dy, double t_max,
                   Visit&& visit) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  // Clip [0, t_max] to the grid's box.
  double t0 = 0.0;
  double t1 = t_max;
  const double lo[2] = {g.origin_x, g.origin_y};
  const double hi[2] = {g.origin_x + g.cell * g.nx, g.origin_y + g.cell * g.ny};
  const double o[2] = {ox, oy};
  const double d[2] = {dx, dy};
  for (int a = 0; a < 2; ++a) {
    if (std::abs(d[a]) < 1e-15) {
      if (o[a] < lo[a] || o[a] >= hi[a]) {
        return;
      }
      continue;
    }
    double ta = (lo[a] - o[a]) / d[a];
    double tb = (hi[a] - o[a]) / d[a];
    if (ta > tb) {
      std::swap(ta, tb);
    }
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  if (t0 > t1) {
    return;
  }
  const double sx = ox + t0 * dx;
  const double sy = oy + t0 * dy;
  int ix = std::clamp(static_cast<int>(std::floor((sx - g.origin_x) / g.cell)), 0, g.nx - 1);
  int iy = std::clamp(static_cast<int>(std::floor((sy - g.origin_y) / g.cell)), 0, g.ny - 1);
  const int step_x = dx > 0 ? 1 : -1;
  const int step_y = dy > 0 ? 1 : -1;
  const double delta_x = std::abs(dx) > 1e-15 ? g.cell / std::abs(dx) : kInf;
  const double delta_y = std::abs(dy) > 1e-15 ? g.cell / std::abs(dy) : kInf;
  const double next_x_edge = g.origin_x + (ix + (dx > 0 ? 1 : 0)) * g.cell;
  const double next_y_edge = g.origin_y + (iy + (dy > 0 ? 1 : 0)) * g.cell;
  double t_next_x = std::abs(dx) > 1e-15 ? (next_x_edge - ox) / dx : kInf;
  double t_next_y = std::abs(dy) > 1e-15 ? (next_y_edge - oy) / dy : kInf;
  double t_enter = t0;
  while (true) {
    const double t_exit = std::min({t_next_x, t_next_y, t1});
    if (!visit(ix, iy, t_enter, t_exit) || t_exit >= t1) {
      return;
    }
    t_enter = t_exit;
    if (t_next_x < t_next_y) {
      ix += step_x;
      t_next_x += delta_x;
      if (ix < 0 || ix >= g.nx) {
        return;
      }
    } else {
      iy += step_y;
      t_next_y += delta_y;
      if (iy < 0 || iy >= g.ny) {
        return;
      }
    }
  }
}

}  // namespace liloc::sim
