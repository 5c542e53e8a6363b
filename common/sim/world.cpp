#include "sim/world.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "sim/grid_traversal.hpp"
#include "sim/random.hpp"

namespace liloc::sim {
namespace {
constexpr double kEps = 1e-9;
// Hits closer than this to the ray origin are the sensor's own housing: ignored.
constexpr double kMinRange = 0.05;

// Ray against a box yawed about z. Returns the entry distance; misses (and rays starting
// inside) return false.
bool intersect_box(const Primitive& p, double c, double s, const Eigen::Vector3d& o,
                   const Eigen::Vector3d& d, double t_max, double& t, Eigen::Vector3d& n) {
  const Eigen::Vector3d r = o - p.center;
  const double lo[3] = {c * r.x() + s * r.y(), -s * r.x() + c * r.y(), r.z()};
  const double ld[3] = {c * d.x() + s * d.y(), -s * d.x() + c * d.y(), d.z()};
  double t_near = -std::numeric_limits<double>::infinity();
  double t_far = t_max;
  int axis = -1;
  for (int a = 0; a < 3; ++a) {
    const double h = p.half_size[a];
    if (std::abs(ld[a]) < kEps) {
      if (std::abs(lo[a]) > h) {
        return false;
      }
      continue;
    }
    double t1 = (-h - lo[a]) / ld[a];
    double t2 = (h - lo[a]) / ld[a];
    if (t1 > t2) {
      std::swap(t1, t2);
    }
    if (t1 > t_near) {
      t_near = t1;
      axis = a;
    }
    t_far = std::min(t_far, t2);
    if (t_near > t_far) {
      return false;
    }
  }
  if (axis < 0 || t_near < kMinRange) {
    return false;
  }
  t = t_near;
  Eigen::Vector3d local_n = Eigen::Vector3d::Zero();
  local_n[axis] = ld[axis] > 0 ? -1.0 : 1.0;
  n = Eigen::Vector3d(c * local_n.x() - s * local_n.y(), s * local_n.x() + c * local_n.y(),
                      local_n.z());
  return true;
}

bool intersect_cylinder(const Primitive& p, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                        double t_max, double& t, Eigen::Vector3d& n) {
  const double radius = p.half_size.x();
  const double z_lo = p.center.z() - p.half_size.z();
  const double z_hi = p.center.z() + p.half_size.z();
  const double rx = o.x() - p.center.x();
  const double ry = o.y() - p.center.y();
  bool hit = false;
  const double a = d.x() * d.x() + d.y() * d.y();
  if (a > kEps) {
    const double b = rx * d.x() + ry * d.y();
    const double cc = rx * rx + ry * ry - radius * radius;
    const double disc = b * b - a * cc;
    if (disc >= 0.0) {
      const double ts = (-b - std::sqrt(disc)) / a;
      const double z = o.z() + ts * d.z();
      if (ts >= kMinRange && ts <= t_max && z >= z_lo && z <= z_hi) {
        t = ts;
        n = Eigen::Vector3d(rx + ts * d.x(), ry + ts * d.y(), 0.0).normalized();
        hit = true;
      }
    }
  }
  if (std::abs(d.z()) > kEps) {
    for (const double zc : {z_lo, z_hi}) {
      const double tc = (zc - o.z()) / d.z();
      if (tc < kMinRange || tc > t_max || (hit && tc >= t)) {
        continue;
      }
      const double px = rx + tc * d.x();
      const double py = ry + tc * d.y();
      if (px * px + py * py <= radius * radius) {
        t = tc;
        n = Eigen::Vector3d(0, 0, d.z() > 0 ? -1.0 : 1.0);
        hit = true;
      }
    }
  }
  return hit;
}

// Foliage: an ellipsoid crown filled with leaves. Leaves are fixed in the world: the
// crown is cut into cells of kLeafCellM, a cell holds a leaf with probability
// 1 - exp(-density * cell) (so a ray loses on average `density` hits per metre), and a
// leaf is a plane with a random point and orientation inside its cell, all drawn from a
// hash of the cell. Rays from any viewpoint hit the same leaves, as in a real tree.
constexpr double kLeafCellM = 0.25;
// A ray through an occupied cell crosses its leaf about this often (measured), so cells
// are filled more densely to keep `density` hits per metre.
constexpr double kLeafCrossFraction = 0.45;

bool intersect_foliage(const Primitive& p, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                       double t_max, double& t, Eigen::Vector3d& n) {
  const Eigen::Vector3d inv_r = p.half_size.cwiseInverse();
  const Eigen::Vector3d lo = (o - p.center).cwiseProduct(inv_r);
  const Eigen::Vector3d ld = d.cwiseProduct(inv_r);
  const double a = ld.squaredNorm();
  const double b = lo.dot(ld);
  const double c = lo.squaredNorm() - 1.0;
  const double disc = b * b - a * c;
  if (disc < 0.0) {
    return false;
  }
  const double root = std::sqrt(disc);
  const double t_in = std::max((-b - root) / a, kMinRange);
  const double t_out = std::min((-b + root) / a, t_max);
  if (t_in >= t_out) {
    return false;
  }
  const double occupancy = 1.0 - std::exp(-p.density_per_m * kLeafCellM / kLeafCrossFraction);
  // 3D cell walk (Amanatides & Woo) from t_in to t_out.
  const Eigen::Vector3d start = o + t_in * d;
  Eigen::Vector3i cell;
  Eigen::Vector3i step;
  Eigen::Vector3d t_next, t_delta;
  for (int k = 0; k < 3; ++k) {
    cell[k] = static_cast<int>(std::floor(start[k] / kLeafCellM));
    step[k] = d[k] > 0 ? 1 : -1;
    if (std::abs(d[k]) < kEps) {
      t_next[k] = t_delta[k] = std::numeric_limits<double>::infinity();
    } else {
      const double edge = (cell[k] + (d[k] > 0 ? 1 : 0)) * kLeafCellM;
      t_next[k] = (edge - o[k]) / d[k];
      t_delta[k] = kLeafCellM / std::abs(d[k]);
    }
  }
  double t_enter = t_in;
  while (t_enter < t_out) {
    int axis = 0;
    for (int k = 1; k < 3; ++k) {
      if (t_next[k] < t_next[axis]) {
        axis = k;
      }
    }
    const double t_exit = std::min(t_next[axis], t_out);
    uint64_t h = hash_combine(p.object_id, static_cast<uint64_t>(static_cast<uint32_t>(cell.x())));
    h = hash_combine(h, static_cast<uint64_t>(static_cast<uint32_t>(cell.y())));
    h = hash_combine(h, static_cast<uint64_t>(static_cast<uint32_t>(cell.z())));
    if (unit_from_hash(h) < occupancy) {
      const Eigen::Vector3d leaf_point =
          kLeafCellM * (cell.cast<double>() + Eigen::Vector3d(unit_from_hash(mix64(h + 1)),
                                                              unit_from_hash(mix64(h + 2)),
                                                              unit_from_hash(mix64(h + 3))));
      const double z = 2.0 * unit_from_hash(mix64(h + 4)) - 1.0;
      const double phi = 2.0 * M_PI * unit_from_hash(mix64(h + 5));
      const double rxy = std::sqrt(std::max(0.0, 1.0 - z * z));
      const Eigen::Vector3d leaf_normal(rxy * std::cos(phi), rxy * std::sin(phi), z);
      const double denom = d.dot(leaf_normal);
      if (std::abs(denom) > kEps) {
        const double t_leaf = (leaf_point - o).dot(leaf_normal) / denom;
        if (t_leaf >= t_enter - 1e-9 && t_leaf <= t_exit + 1e-9) {
          t = t_leaf;
          n = denom > 0 ? -leaf_normal : leaf_normal;
          return true;
        }
      }
    }
    t_enter = t_exit;
    cell[axis] += step[axis];
    t_next[axis] += t_delta[axis];
  }
  return false;
}
}  // namespace

double Heightfield::height_at(double x, double y) const {
  const double fx = std::clamp((x - origin_x_m) / resolution_m, 0.0, nx - 1.000001);
  const double fy = std::clamp((y - origin_y_m) / resolution_m, 0.0, ny - 1.000001);
  const int ix = static_cast<int>(fx);
  const int iy = static_cast<int>(fy);
  const double u = fx - ix;
  const double v = fy - iy;
  const double h00 = vertex(ix, iy);
  const double h10 = vertex(ix + 1, iy);
  const double h01 = vertex(ix, iy + 1);
  const double h11 = vertex(ix + 1, iy + 1);
  if (u >= v) {
    return h00 + (h10 - h00) * u + (h11 - h10) * v;
  }
  return h00 + (h11 - h01) * u + (h01 - h00) * v;
}

World::World(Heightfield ground, std::vector<WorldObject> objects, RoadNetwork roads,
             Eigen::AlignedBox2d bounds, double grid_cell_m)
    : ground_(std::move(ground)),
      objects_(std::move(objects)),
      roads_(std::move(roads)),
      bounds_(bounds),
      cell_m_(grid_cell_m) {
  ground_max_m_ = *std::max_element(ground_.heights_m.begin(), ground_.heights_m.end());
  build_index();
}

void World::set_objects(std::vector<WorldObject> objects) {
  objects_ = std::move(objects);
  build_index();
}

void World::build_index() {
  primitives_.clear();
  yaw_cos_sin_.clear();
  for (const WorldObject& object : objects_) {
    for (Primitive p : object.primitives) {
      p.object_id = object.id;
      primitives_.push_back(p);
      yaw_cos_sin_.emplace_back(std::cos(p.yaw_rad), std::sin(p.yaw_rad));
    }
  }
  cells_x_ = static_cast<int>(std::ceil(bounds_.sizes().x() / cell_m_));
  cells_y_ = static_cast<int>(std::ceil(bounds_.sizes().y() / cell_m_));
  const size_t num_cells = static_cast<size_t>(cells_x_) * cells_y_;
  // Two passes (count, then fill) give the compressed-row layout.
  std::vector<std::vector<uint32_t>> per_cell(num_cells);
  for (size_t i = 0; i < primitives_.size(); ++i) {
    const Primitive& p = primitives_[i];
    // Footprint radius in xy: the half-diagonal for boxes, the radius otherwise.
    const double r = p.shape == Primitive::Shape::kBox ? p.half_size.head<2>().norm()
                                                       : p.half_size.head<2>().maxCoeff();
    const int x0 = std::max(0, static_cast<int>((p.center.x() - r - bounds_.min().x()) / cell_m_));
    const int x1 =
        std::min(cells_x_ - 1, static_cast<int>((p.center.x() + r - bounds_.min().x()) / cell_m_));
    const int y0 = std::max(0, static_cast<int>((p.center.y() - r - bounds_.min().y()) / cell_m_));
    const int y1 =
        std::min(cells_y_ - 1, static_cast<int>((p.center.y() + r - bounds_.min().y()) / cell_m_));
    for (int iy = y0; iy <= y1; ++iy) {
      for (int ix = x0; ix <= x1; ++ix) {
        per_cell[ix + static_cast<size_t>(cells_x_) * iy].push_back(static_cast<uint32_t>(i));
      }
    }
  }
  cell_start_.assign(num_cells + 1, 0);
  cell_items_.clear();
  for (size_t c = 0; c < num_cells; ++c) {
    cell_start_[c] = static_cast<uint32_t>(cell_items_.size());
    cell_items_.insert(cell_items_.end(), per_cell[c].begin(), per_cell[c].end());
  }
  cell_start_[num_cells] = static_cast<uint32_t>(cell_items_.size());
}

std::optional<RayHit> World::raycast(const Eigen::Vector3d& origin,
                                     const Eigen::Vector3d& direction, double max_range_m,
                                     RaycastScratch& scratch) const {
  if (scratch.last_ray.size() != primitives_.size()) {
    scratch.last_ray.assign(primitives_.size(), 0);
    scratch.ray_counter = 0;
  }
  const uint32_t ray_id = ++scratch.ray_counter;
  RayHit best;
  double best_t = max_range_m;
  bool found = false;
  const Grid2d grid{bounds_.min().x(), bounds_.min().y(), cell_m_, cells_x_, cells_y_};
  traverse_grid(grid, origin.x(), origin.y(), direction.x(), direction.y(), max_range_m,
                [&](int ix, int iy, double t_enter, double) {
                  if (t_enter > best_t) {
                    return false;  // every later cell starts beyond the nearest hit
                  }
                  const size_t c = ix + static_cast<size_t>(cells_x_) * iy;
                  for (uint32_t k = cell_start_[c]; k < cell_start_[c + 1]; ++k) {
                    const uint32_t i = cell_items_[k];
                    if (scratch.last_ray[i] == ray_id) {
                      continue;
                    }
                    scratch.last_ray[i] = ray_id;
                    const Primitive& p = primitives_[i];
                    double t = 0.0;
                    Eigen::Vector3d n;
                    bool hit = false;
                    switch (p.shape) {
                      case Primitive::Shape::kBox:
                        hit = intersect_box(p, yaw_cos_sin_[i].x(), yaw_cos_sin_[i].y(), origin,
                                            direction, best_t, t, n);
                        break;
                      case Primitive::Shape::kCylinder:
                        hit = intersect_cylinder(p, origin, direction, best_t, t, n);
                        break;
                      case Primitive::Shape::kFoliage:
                        hit = intersect_foliage(p, origin, direction, best_t, t, n);
                        break;
                    }
                    if (hit && t < best_t) {
                      best_t = t;
                      best.range_m = t;
                      best.normal = n;
                      best.reflectivity = p.reflectivity;
                      best.object_id = p.object_id;
                      found = true;
                    }
                  }
                  return true;
                });
  RayHit ground;
  if (ground_hit(origin, direction, best_t, ground)) {
    return ground;
  }
  if (!found) {
    return std::nullopt;
  }
  return best;
}

bool World::ground_hit(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_max,
                       RayHit& hit) const {
  if (d.z() >= 0.0 && o.z() > ground_max_m_) {
    return false;
  }
  const Heightfield& g = ground_;
  const Grid2d grid{g.origin_x_m, g.origin_y_m, g.resolution_m, g.nx - 1, g.ny - 1};
  const double inv_res = 1.0 / g.resolution_m;
  bool found = false;
  traverse_grid(
      grid, o.x(), o.y(), d.x(), d.y(), t_max, [&](int ix, int iy, double t_enter, double t_exit) {
        const float h00 = g.vertex(ix, iy);
        const float h10 = g.vertex(ix + 1, iy);
        const float h01 = g.vertex(ix, iy + 1);
        const float h11 = g.vertex(ix + 1, iy + 1);
        const double cell_max = std::max({h00, h10, h01, h11});
        const double z_low = o.z() + std::min(t_enter * d.z(), t_exit * d.z());
        if (z_low > cell_max) {
          return true;
        }
        const double u0 = (o.x() - (g.origin_x_m + ix * g.resolution_m)) * inv_res;
        const double v0 = (o.y() - (g.origin_y_m + iy * g.resolution_m)) * inv_res;
        const double du = d.x() * inv_res;
        const double dv = d.y() * inv_res;
        // The two triangles: z = h0 + a u + b v.
        const double planes[2][3] = {{h00, h10 - h00, h11 - h10}, {h00, h11 - h01, h01 - h00}};
        for (int k = 0; k < 2; ++k) {
          const double a = planes[k][1];
          const double b = planes[k][2];
          const double den = d.z() - a * du - b * dv;
          if (den >= 0.0) {
            continue;  // moving away from (or along) this plane
          }
          const double t = (planes[k][0] + a * u0 + b * v0 - o.z()) / den;
          if (t < t_enter - 1e-9 || t > t_exit + 1e-9 || t < kMinRange) {
            continue;
          }
          const double u = u0 + t * du;
          const double v = v0 + t * dv;
          if ((k == 0) != (u >= v)) {
            continue;
          }
          hit.range_m = t;
          hit.normal = Eigen::Vector3d(-a * inv_res, -b * inv_res, 1.0).normalized();
          hit.reflectivity = g.reflectivity[ix + static_cast<size_t>(g.nx - 1) * iy];
          hit.object_id = kGroundId;
          found = true;
          return false;
        }
        return true;
      });
  return found;
}

double World::distance_to_surface(const Eigen::Vector3d& p, double search_radius_m) const {
  return std::min(std::abs(p.z() - ground_.height_at(p.x(), p.y())),
                  distance_to_objects(p, search_radius_m));
}

double World::distance_to_objects(const Eigen::Vector3d& p, double search_radius_m) const {
  double best = std::numeric_limits<double>::infinity();
  const int cx = static_cast<int>((p.x() - bounds_.min().x()) / cell_m_);
  const int cy = static_cast<int>((p.y() - bounds_.min().y()) / cell_m_);
  const int reach = static_cast<int>(std::ceil(search_radius_m / cell_m_));
  for (int iy = std::max(0, cy - reach); iy <= std::min(cells_y_ - 1, cy + reach); ++iy) {
    for (int ix = std::max(0, cx - reach); ix <= std::min(cells_x_ - 1, cx + reach); ++ix) {
      const size_t c = ix + static_cast<size_t>(cells_x_) * iy;
      for (uint32_t k = cell_start_[c]; k < cell_start_[c + 1]; ++k) {
        const Primitive& q = primitives_[cell_items_[k]];
        const Eigen::Vector3d r = p - q.center;
        double dist = 0.0;
        switch (q.shape) {
          case Primitive::Shape::kBox: {
            const double c_yaw = std::cos(q.yaw_rad);
            const double s_yaw = std::sin(q.yaw_rad);
            const Eigen::Vector3d local(c_yaw * r.x() + s_yaw * r.y(),
                                        -s_yaw * r.x() + c_yaw * r.y(), r.z());
            const Eigen::Vector3d excess = local.cwiseAbs() - q.half_size;
            dist = excess.maxCoeff() > 0.0 ? excess.cwiseMax(0.0).norm() : -excess.maxCoeff();
            break;
          }
          case Primitive::Shape::kCylinder: {
            const double dr = r.head<2>().norm() - q.half_size.x();
            const double dz = std::abs(r.z()) - q.half_size.z();
            dist = (dr > 0.0 || dz > 0.0)
                       ? Eigen::Vector2d(std::max(dr, 0.0), std::max(dz, 0.0)).norm()
                       : std::min(-dr, -dz);
            break;
          }
          case Primitive::Shape::kFoliage: {
            const double scaled = r.cwiseQuotient(q.half_size).norm();
            dist = scaled <= 1.0 ? 0.0 : (scaled - 1.0) * q.half_size.minCoeff();
            break;
          }
        }
        best = std::min(best, dist);
      }
    }
  }
  return best;
}

}  // namespace liloc::sim
