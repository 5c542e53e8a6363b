#include "sim/world_generator.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "sim/random.hpp"

namespace liloc::sim {
namespace {

// Reflectivities (0..1) of the materials, as a LiDAR sees them.
constexpr float kAsphalt = 0.08f;
constexpr float kLaneMarking = 0.55f;
constexpr float kSidewalk = 0.28f;
constexpr float kGrass = 0.18f;
constexpr float kConcrete = 0.32f;
constexpr float kFacade = 0.4f;
constexpr float kGlass = 0.15f;
constexpr float kCarPaint = 0.6f;
constexpr float kBark = 0.22f;
constexpr float kLeaves = 0.35f;
constexpr float kMetal = 0.7f;

Primitive box(const Eigen::Vector3d& center, const Eigen::Vector3d& size, double yaw,
              float reflectivity) {
  Primitive p;
  p.shape = Primitive::Shape::kBox;
  p.center = center;
  p.half_size = 0.5 * size;
  p.yaw_rad = yaw;
  p.reflectivity = reflectivity;
  return p;
}

Primitive cylinder(const Eigen::Vector3d& base, double radius, double height, float reflectivity) {
  Primitive p;
  p.shape = Primitive::Shape::kCylinder;
  p.center = base + Eigen::Vector3d(0, 0, 0.5 * height);
  p.half_size = Eigen::Vector3d(radius, radius, 0.5 * height);
  p.reflectivity = reflectivity;
  return p;
}

Primitive foliage(const Eigen::Vector3d& center, const Eigen::Vector3d& radii, float density) {
  Primitive p;
  p.shape = Primitive::Shape::kFoliage;
  p.center = center;
  p.half_size = radii;
  p.reflectivity = kLeaves;
  p.density_per_m = density;
  return p;
}

class Builder {
 public:
  Builder(const WorldConfig& config, Random& rng) : config_(config), rng_(rng) {}

  WorldObject& add(ObjectClass object_class, bool movable = false) {
    WorldObject o;
    o.id = static_cast<uint32_t>(objects_.size());
    o.object_class = object_class;
    o.movable = movable;
    objects_.push_back(o);
    return objects_.back();
  }

  void tree(const Eigen::Vector2d& xy, double ground_z) {
    WorldObject& t = add(ObjectClass::kTree);
    const double trunk_h = rng_.uniform(2.0, 4.0);
    t.primitives.push_back(cylinder(Eigen::Vector3d(xy.x(), xy.y(), ground_z - 0.2),
                                    rng_.uniform(0.12, 0.3), trunk_h + 0.2, kBark));
    const double r = rng_.uniform(1.8, 3.5);
    const double rz = rng_.uniform(1.8, 3.5);
    t.primitives.push_back(foliage(Eigen::Vector3d(xy.x(), xy.y(), ground_z + trunk_h + 0.8 * rz),
                                   Eigen::Vector3d(r, r * rng_.uniform(0.85, 1.15), rz),
                                   static_cast<float>(rng_.uniform(0.6, 1.6))));
  }

  void bush(const Eigen::Vector2d& xy, double ground_z) {
    WorldObject& b = add(ObjectClass::kBush);
    const double r = rng_.uniform(0.6, 1.4);
    b.primitives.push_back(foliage(Eigen::Vector3d(xy.x(), xy.y(), ground_z + 0.5 * r),
                                   Eigen::Vector3d(r, r * rng_.uniform(0.7, 1.3), 0.7 * r),
                                   static_cast<float>(rng_.uniform(1.5, 3.0))));
  }

  void pole(const Eigen::Vector2d& xy, double ground_z, double yaw_to_road) {
    WorldObject& p = add(ObjectClass::kPole);
    const double h = rng_.uniform(6.0, 8.0);
    p.primitives.push_back(cylinder(Eigen::Vector3d(xy.x(), xy.y(), ground_z - 0.2),
                                    rng_.uniform(0.1, 0.16), h + 0.2, kMetal));
    // The lamp arm reaching over the road.
    const Eigen::Vector2d arm =
        xy + 0.8 * Eigen::Vector2d(std::cos(yaw_to_road), std::sin(yaw_to_road));
    p.primitives.push_back(box(Eigen::Vector3d(arm.x(), arm.y(), ground_z + h - 0.1),
                               Eigen::Vector3d(1.8, 0.25, 0.15), yaw_to_road, kMetal));
  }

  void car(const Eigen::Vector2d& xy, double ground_z, double yaw) {
    WorldObject& c = add(ObjectClass::kCar, true);
    const double length = rng_.uniform(4.0, 4.9);
    const double width = rng_.uniform(1.7, 1.9);
    const float paint = static_cast<float>(rng_.uniform(0.3, 0.9)) * kCarPaint / 0.6f;
    c.primitives.push_back(box(Eigen::Vector3d(xy.x(), xy.y(), ground_z + 0.75),
                               Eigen::Vector3d(length, width, 0.9), yaw, paint));
    const bool van = rng_.bernoulli(0.15);
    const double cabin_l = van ? length * 0.9 : length * rng_.uniform(0.45, 0.6);
    const double cabin_h = van ? 1.0 : 0.55;
    c.primitives.push_back(box(Eigen::Vector3d(xy.x(), xy.y(), ground_z + 1.2 + 0.5 * cabin_h),
                               Eigen::Vector3d(cabin_l, width - 0.1, cabin_h), yaw, kGlass));
  }

  void building(const Eigen::Vector2d& xy, const Eigen::Vector2d& size, double yaw,
                double ground_z) {
    WorldObject& b = add(ObjectClass::kBuilding);
    const double h = rng_.uniform(6.0, 25.0);
    // Foundations reach below the lowest terrain around them.
    b.primitives.push_back(box(Eigen::Vector3d(xy.x(), xy.y(), ground_z - 1.0 + 0.5 * (h + 1.0)),
                               Eigen::Vector3d(size.x(), size.y(), h + 1.0), yaw, kFacade));
    const Eigen::Vector2d ax(std::cos(yaw), std::sin(yaw));
    const Eigen::Vector2d ay(-ax.y(), ax.x());
    // An L-shaped wing, a roof structure, and pillars or a canopy at the entrance give
    // the facades the structure of real buildings.
    if (rng_.bernoulli(0.5)) {
      const double wx = size.x() * rng_.uniform(0.3, 0.5);
      const double wy = size.y() * rng_.uniform(0.3, 0.6);
      const double wh = h * rng_.uniform(0.4, 0.9);
      const Eigen::Vector2d c =
          xy + ax * (0.5 * size.x() - 0.5 * wx) + ay * (0.5 * size.y() + 0.5 * wy - 0.5);
      b.primitives.push_back(box(Eigen::Vector3d(c.x(), c.y(), ground_z - 1.0 + 0.5 * (wh + 1.0)),
                                 Eigen::Vector3d(wx, wy, wh + 1.0), yaw, kFacade));
    }
    if (rng_.bernoulli(0.6)) {
      const double rx = rng_.uniform(2.0, 6.0);
      const Eigen::Vector2d c = xy + ax * rng_.uniform(-0.3, 0.3) * size.x();
      b.primitives.push_back(box(Eigen::Vector3d(c.x(), c.y(), ground_z + h + 1.0),
                                 Eigen::Vector3d(rx, rx, 2.0), yaw, kMetal));
    }
    const int pillars = rng_.uniform_int(0, 4);
    for (int i = 0; i < pillars; ++i) {
      const double along = (i + 0.5) / pillars - 0.5;
      const Eigen::Vector2d c = xy + ax * along * size.x() * 0.8 - ay * (0.5 * size.y() + 1.5);
      b.primitives.push_back(
          cylinder(Eigen::Vector3d(c.x(), c.y(), ground_z - 0.5), 0.3, 4.5, kConcrete));
    }
    if (pillars > 0) {
      const Eigen::Vector2d c = xy - ay * (0.5 * size.y() + 1.0);
      b.primitives.push_back(box(Eigen::Vector3d(c.x(), c.y(), ground_z + 4.1),
                                 Eigen::Vector3d(size.x() * 0.85, 3.0, 0.4), yaw, kConcrete));
    }
  }

  void wall(const Eigen::Vector2d& a, const Eigen::Vector2d& b, double height, double ground_z) {
    WorldObject& w = add(ObjectClass::kWall);
    const Eigen::Vector2d mid = 0.5 * (a + b);
    const Eigen::Vector2d d = b - a;
    w.primitives.push_back(
        box(Eigen::Vector3d(mid.x(), mid.y(), ground_z - 0.5 + 0.5 * (height + 0.5)),
            Eigen::Vector3d(d.norm(), 0.3, height + 0.5), std::atan2(d.y(), d.x()), kConcrete));
  }

  std::vector<WorldObject> take() { return std::move(objects_); }

 private:
  const WorldConfig& config_;
  Random& rng_;
  std::vector<WorldObject> objects_;
};

// Rolling terrain: a few long-wavelength sinusoids with random directions.
struct Terrain {
  struct Wave {
    Eigen::Vector2d direction;
    double wavelength_m;
    double amplitude_m;
    double phase;
  };
  std::vector<Wave> waves;

  Terrain(double peak_to_peak_m, Random& rng) {
    for (int i = 0; i < 4; ++i) {
      const double angle = rng.uniform(0.0, 2.0 * M_PI);
      waves.push_back({Eigen::Vector2d(std::cos(angle), std::sin(angle)), rng.uniform(150.0, 400.0),
                       peak_to_peak_m / 8.0, rng.uniform(0.0, 6.3)});
    }
  }
  double height(double x, double y) const {
    double h = 0.0;
    for (const Wave& w : waves) {
      h += w.amplitude_m *
           std::sin(2.0 * M_PI * w.direction.dot(Eigen::Vector2d(x, y)) / w.wavelength_m + w.phase);
    }
    return h;
  }
};

Heightfield make_heightfield(const Eigen::AlignedBox2d& bounds, double resolution) {
  Heightfield g;
  g.origin_x_m = bounds.min().x();
  g.origin_y_m = bounds.min().y();
  g.resolution_m = resolution;
  g.nx = static_cast<int>(std::ceil(bounds.sizes().x() / resolution)) + 1;
  g.ny = static_cast<int>(std::ceil(bounds.sizes().y() / resolution)) + 1;
  g.heights_m.assign(static_cast<size_t>(g.nx) * g.ny, 0.0f);
  g.reflectivity.assign(static_cast<size_t>(g.nx - 1) * (g.ny - 1), kGrass);
  return g;
}

// Distance from p to segment ab and the position along it (0..1).
double segment_distance(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                        const Eigen::Vector2d& b, double* along = nullptr) {
  const Eigen::Vector2d ab = b - a;
  const double s = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  if (along != nullptr) {
    *along = s;
  }
  return (a + s * ab - p).norm();
}

GeneratedWorld generate_campus(const WorldConfig& config) {
  Random rng(mix64(static_cast<uint64_t>(config.seed)));
  const Eigen::AlignedBox2d campus(Eigen::Vector2d(0, 0),
                                   Eigen::Vector2d(config.size_x_m, config.size_y_m));
  const Eigen::AlignedBox2d bounds(campus.min() - Eigen::Vector2d::Constant(config.margin_m),
                                   campus.max() + Eigen::Vector2d::Constant(config.margin_m));

  // Road grid with jittered intersections.
  const int nx = static_cast<int>(std::floor(config.size_x_m / config.block_m)) + 1;
  const int ny = static_cast<int>(std::floor(config.size_y_m / config.block_m)) + 1;
  const double x0 = 0.5 * (config.size_x_m - (nx - 1) * config.block_m);
  const double y0 = 0.5 * (config.size_y_m - (ny - 1) * config.block_m);
  std::vector<Eigen::Vector2d> nodes;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      nodes.emplace_back(x0 + i * config.block_m + rng.uniform(-1, 1) * config.node_jitter_m,
                         y0 + j * config.block_m + rng.uniform(-1, 1) * config.node_jitter_m);
    }
  }
  std::vector<std::pair<int, int>> edges;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      if (i + 1 < nx) {
        edges.emplace_back(i + nx * j, i + 1 + nx * j);
      }
      if (j + 1 < ny) {
        edges.emplace_back(i + nx * j, i + nx * (j + 1));
      }
    }
  }
  RoadNetwork roads(nodes, edges, config.road_width_m, config.lane_offset_m);
  const double half_road = 0.5 * config.road_width_m;

  // Terrain, road surfaces, lane markings, sidewalks, speed humps.
  Heightfield ground = make_heightfield(bounds, config.ground_resolution_m);
  const Terrain terrain(config.terrain_amplitude_m, rng);
  std::vector<std::pair<int, double>> humps;  // (edge, position along it 0..1)
  for (size_t e = 0; e < edges.size(); ++e) {
    if (rng.bernoulli(config.speed_hump_probability)) {
      humps.emplace_back(static_cast<int>(e), rng.uniform(0.35, 0.65));
    }
  }
  for (int iy = 0; iy < ground.ny; ++iy) {
    for (int ix = 0; ix < ground.nx; ++ix) {
      const Eigen::Vector2d p(ground.origin_x_m + ix * ground.resolution_m,
                              ground.origin_y_m + iy * ground.resolution_m);
      double h = terrain.height(p.x(), p.y());
      // Speed humps: 12 cm, 4 m long (a "speed table" a 1 m grid resolves).
      for (const auto& [e, at] : humps) {
        const Eigen::Vector2d a = nodes[edges[e].first];
        const Eigen::Vector2d b = nodes[edges[e].second];
        const Eigen::Vector2d dir = (b - a).normalized();
        const Eigen::Vector2d c = a + at * (b - a);
        const double along = (p - c).dot(dir);
        const double across = std::abs((p - c).dot(Eigen::Vector2d(-dir.y(), dir.x())));
        if (std::abs(along) < 2.0 && across < half_road) {
          h += 0.12 * std::pow(std::cos(M_PI * along / 4.0), 2);
        }
      }
      ground.heights_m[ix + static_cast<size_t>(ground.nx) * iy] = static_cast<float>(h);
    }
  }
  for (int iy = 0; iy + 1 < ground.ny; ++iy) {
    for (int ix = 0; ix + 1 < ground.nx; ++ix) {
      const Eigen::Vector2d p(ground.origin_x_m + (ix + 0.5) * ground.resolution_m,
                              ground.origin_y_m + (iy + 0.5) * ground.resolution_m);
      float r = static_cast<float>(kGrass * rng.uniform(0.8, 1.2));
      for (const auto& [a, b] : edges) {
        double along = 0.0;
        const double d = segment_distance(p, nodes[a], nodes[b], &along);
        if (d < half_road) {
          const double s = along * (nodes[b] - nodes[a]).norm();
          const bool dash = d < 0.5 && std::fmod(s, 6.0) < 3.0;
          r = dash ? kLaneMarking : kAsphalt;
          break;
        }
        if (d < half_road + 3.0) {
          r = kSidewalk;
        }
      }
      ground.reflectivity[ix + static_cast<size_t>(ground.nx - 1) * iy] = r;
    }
  }
  const auto ground_z = [&](const Eigen::Vector2d& p) { return ground.height_at(p.x(), p.y()); };

  Builder builder(config, rng);
  // Along each road: curbs, trees, lamp poles and parked cars.
  for (const auto& [a, b] : edges) {
    const Eigen::Vector2d pa = nodes[a];
    const Eigen::Vector2d pb = nodes[b];
    const Eigen::Vector2d dir = (pb - pa).normalized();
    const Eigen::Vector2d left(-dir.y(), dir.x());
    const double length = (pb - pa).norm();
    const double yaw = std::atan2(dir.y(), dir.x());
    const double clear = half_road + 3.0;  // keep intersections free
    for (const double side : {-1.0, 1.0}) {
      const Eigen::Vector2d curb_mid = 0.5 * (pa + pb) + side * half_road * left;
      WorldObject& curb = builder.add(ObjectClass::kCurb);
      const double curb_len = length - 2.0 * clear;
      // Curbs follow the terrain in 5 m pieces.
      const int pieces = std::max(1, static_cast<int>(curb_len / 5.0));
      for (int k = 0; k < pieces; ++k) {
        const Eigen::Vector2d c = curb_mid + dir * ((k + 0.5) / pieces - 0.5) * curb_len;
        curb.primitives.push_back(box(Eigen::Vector3d(c.x(), c.y(), ground_z(c) + 0.02),
                                      Eigen::Vector3d(curb_len / pieces, 0.25, 0.3), yaw,
                                      kConcrete));
      }
      for (double s = clear + rng.uniform(0, 6); s < length - clear; s += rng.uniform(9, 16)) {
        if (rng.bernoulli(0.6)) {
          const Eigen::Vector2d p = pa + dir * s + side * (half_road + 2.5) * left;
          builder.tree(p, ground_z(p));
        }
      }
      for (double s = clear + rng.uniform(0, 10); s < length - clear; s += rng.uniform(25, 35)) {
        const Eigen::Vector2d p = pa + dir * s + side * (half_road + 0.8) * left;
        builder.pole(p, ground_z(p), std::atan2(-side * left.y(), -side * left.x()));
      }
      for (double s = clear + 3.0; s < length - clear - 3.0; s += 6.5) {
        if (rng.bernoulli(0.3)) {
          const Eigen::Vector2d p = pa + dir * s + side * (half_road - 1.1) * left;
          builder.car(p, ground_z(p), side > 0 ? yaw + M_PI : yaw);
        }
      }
    }
  }

  // Blocks between roads.
  const double inset = half_road + 4.5;
  for (int j = 0; j + 1 < ny; ++j) {
    for (int i = 0; i + 1 < nx; ++i) {
      const Eigen::Vector2d c00 = nodes[i + nx * j];
      const Eigen::Vector2d c11 = nodes[i + 1 + nx * (j + 1)];
      const Eigen::Vector2d c10 = nodes[i + 1 + nx * j];
      const Eigen::Vector2d c01 = nodes[i + nx * (j + 1)];
      const double bx0 = std::max(c00.x(), c01.x()) + inset;
      const double bx1 = std::min(c10.x(), c11.x()) - inset;
      const double by0 = std::max(c00.y(), c10.y()) + inset;
      const double by1 = std::min(c01.y(), c11.y()) - inset;
      if (bx1 - bx0 < 10 || by1 - by0 < 10) {
        continue;
      }
      const Eigen::Vector2d center(0.5 * (bx0 + bx1), 0.5 * (by0 + by1));
      const Eigen::Vector2d extent(bx1 - bx0, by1 - by0);
      const double kind = rng.uniform();
      if (kind < 0.55) {
        // One to three buildings side by side.
        const int count = rng.uniform_int(1, 3);
        for (int k = 0; k < count; ++k) {
          const double slot = extent.x() / count;
          const Eigen::Vector2d size(slot * rng.uniform(0.55, 0.85),
                                     extent.y() * rng.uniform(0.4, 0.8));
          const Eigen::Vector2d c(bx0 + slot * (k + 0.5),
                                  center.y() + rng.uniform(-0.5, 0.5) * (extent.y() - size.y()));
          builder.building(c, size, rng.uniform(-0.08, 0.08), ground_z(c));
        }
        if (rng.bernoulli(0.4)) {
          builder.wall(Eigen::Vector2d(bx0, by0 - 1.5), Eigen::Vector2d(bx1, by0 - 1.5),
                       rng.uniform(1.0, 2.2), ground_z(Eigen::Vector2d(center.x(), by0)));
        }
      } else if (kind < 0.7) {
        // Parking lot: rows of cars and lamp poles.
        for (double y = by0 + 4; y < by1 - 4; y += 12) {
          for (double x = bx0 + 2; x < bx1 - 2; x += 2.8) {
            if (rng.bernoulli(0.65)) {
              const Eigen::Vector2d p(x, y + rng.uniform(-0.3, 0.3));
              builder.car(p, ground_z(p), M_PI / 2 + (rng.bernoulli(0.5) ? 0 : M_PI));
            }
          }
          const Eigen::Vector2d lamp(center.x(), y + 6);
          builder.pole(lamp, ground_z(lamp), 0.0);
        }
      } else if (kind < 0.9) {
        // Park: trees and bushes.
        const int trees = rng.uniform_int(6, 16);
        for (int k = 0; k < trees; ++k) {
          const Eigen::Vector2d p(rng.uniform(bx0, bx1), rng.uniform(by0, by1));
          builder.tree(p, ground_z(p));
        }
        const int bushes = rng.uniform_int(4, 12);
        for (int k = 0; k < bushes; ++k) {
          const Eigen::Vector2d p(rng.uniform(bx0, bx1), rng.uniform(by0, by1));
          builder.bush(p, ground_z(p));
        }
      } else {
        // Plaza: a kiosk, bollards, a few trees.
        WorldObject& kiosk = builder.add(ObjectClass::kStructure);
        kiosk.primitives.push_back(
            box(Eigen::Vector3d(center.x(), center.y(), ground_z(center) + 1.5),
                Eigen::Vector3d(4, 3, 3), rng.uniform(0, M_PI), kFacade));
        for (int k = 0; k < 12; ++k) {
          const double angle = k * 2.0 * M_PI / 12;
          const Eigen::Vector2d p =
              center + 10.0 * Eigen::Vector2d(std::cos(angle), std::sin(angle));
          WorldObject& bollard = builder.add(ObjectClass::kPole);
          bollard.primitives.push_back(
              cylinder(Eigen::Vector3d(p.x(), p.y(), ground_z(p) - 0.2), 0.15, 1.2, kMetal));
        }
        for (int k = 0; k < 4; ++k) {
          const Eigen::Vector2d p(rng.uniform(bx0, bx1), rng.uniform(by0, by1));
          builder.tree(p, ground_z(p));
        }
      }
    }
  }

  // Open terrain around the campus: scattered trees and bushes.
  const double ring = config.margin_m;
  for (int k = 0; k < static_cast<int>(ring * (config.size_x_m + config.size_y_m) / 150.0); ++k) {
    const Eigen::Vector2d p(rng.uniform(bounds.min().x(), bounds.max().x()),
                            rng.uniform(bounds.min().y(), bounds.max().y()));
    if (campus.exteriorDistance(p) < 8.0) {
      continue;
    }
    if (rng.bernoulli(0.7)) {
      builder.tree(p, ground_z(p));
    } else {
      builder.bush(p, ground_z(p));
    }
  }

  return {World(std::move(ground), builder.take(), std::move(roads), bounds, config.grid_cell_m),
          config.mapped_fraction_x * config.size_x_m};
}

GeneratedWorld generate_corridor(const WorldConfig& config) {
  Random rng(mix64(static_cast<uint64_t>(config.seed) + 17));
  const double L = config.corridor_length_m;
  const double S = config.corridor_spacing_m;
  const double w = config.corridor_width_m;
  const double H = config.corridor_height_m;
  const Eigen::AlignedBox2d bounds(Eigen::Vector2d(-w - 5, -w - 5),
                                   Eigen::Vector2d(L + w + 5, S + w + 5));
  Heightfield ground = make_heightfield(bounds, config.ground_resolution_m);
  std::fill(ground.reflectivity.begin(), ground.reflectivity.end(), kConcrete);

  Builder builder(config, rng);
  WorldObject& tunnel = builder.add(ObjectClass::kTunnel);
  const double half = 0.5 * w;
  const double outer_x0 = -half - 0.5, outer_x1 = L + half + 0.5;
  const double outer_y0 = -half - 0.5, outer_y1 = S + half + 0.5;
  const auto wall_box = [&](double x0, double x1, double y0, double y1) {
    tunnel.primitives.push_back(
        box(Eigen::Vector3d(0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5 * H - 0.25),
            Eigen::Vector3d(x1 - x0, y1 - y0, H + 0.5), 0.0, kConcrete));
  };
  // Outer walls (1 m thick) and the solid core between the two long tunnels.
  wall_box(outer_x0 - 0.5, outer_x1 + 0.5, outer_y0 - 0.5, outer_y0 + 0.5);
  wall_box(outer_x0 - 0.5, outer_x1 + 0.5, outer_y1 - 0.5, outer_y1 + 0.5);
  wall_box(outer_x0 - 0.5, outer_x0 + 0.5, outer_y0, outer_y1);
  wall_box(outer_x1 - 0.5, outer_x1 + 0.5, outer_y0, outer_y1);
  wall_box(half, L - half, half, S - half);
  tunnel.primitives.push_back(box(Eigen::Vector3d(0.5 * L, 0.5 * S, H + 0.5),
                                  Eigen::Vector3d(L + w + 4, S + w + 4, 1.0), 0.0, kConcrete));
  // Sparse features: ceiling lights every 25 m and a niche with a cabinet every 60-100 m.
  // Along the long tunnels nothing else constrains motion along the axis.
  for (const double y : {0.0, S}) {
    for (double x = 10; x < L; x += 25) {
      WorldObject& light = builder.add(ObjectClass::kStructure);
      light.primitives.push_back(
          box(Eigen::Vector3d(x, y, H - 0.1), Eigen::Vector3d(1.2, 0.3, 0.2), 0.0, kMetal));
    }
    for (double x = rng.uniform(30, 60); x < L - 20; x += rng.uniform(60, 100)) {
      const double side = rng.bernoulli(0.5) ? 1.0 : -1.0;
      WorldObject& cabinet = builder.add(ObjectClass::kStructure);
      cabinet.primitives.push_back(box(Eigen::Vector3d(x, y + side * (half - 0.3), 1.0),
                                       Eigen::Vector3d(1.5, 0.6, 2.0), 0.0, kMetal));
    }
  }
  std::vector<Eigen::Vector2d> nodes = {{0, 0}, {L, 0}, {L, S}, {0, S}};
  std::vector<std::pair<int, int>> edges = {{0, 1}, {1, 2}, {2, 3}, {3, 0}};
  RoadNetwork roads(nodes, edges, w, 0.0);
  return {World(std::move(ground), builder.take(), std::move(roads), bounds, config.grid_cell_m),
          L + w};
}

}  // namespace

void WorldConfig::validate() const {
  if (kind != "campus" && kind != "corridor") {
    throw std::invalid_argument("kind must be 'campus' or 'corridor', not '" + kind + "'");
  }
  if (size_x_m < 2 * block_m || size_y_m < 2 * block_m) {
    throw std::invalid_argument("size_x_m and size_y_m must be at least 2 * block_m");
  }
  if (road_width_m < 6.0 || lane_offset_m < 0.0 || lane_offset_m > 0.5 * road_width_m) {
    throw std::invalid_argument(
        "road_width_m must be >= 6 and lane_offset_m in [0, road_width_m/2]");
  }
  if (grid_cell_m <= 0.0 || ground_resolution_m <= 0.0) {
    throw std::invalid_argument("grid_cell_m and ground_resolution_m must be positive");
  }
  if (mapped_fraction_x <= 0.0 || mapped_fraction_x > 1.0) {
    throw std::invalid_argument("mapped_fraction_x must be in (0, 1]");
  }
}

GeneratedWorld generate_world(const WorldConfig& config) {
  config.validate();
  return config.kind == "corridor" ? generate_corridor(config) : generate_campus(config);
}

void DayChangeConfig::validate() const {
  const auto fraction = [](double f) { return f >= 0.0 && f <= 1.0; };
  if (!fraction(movable_change_fraction) || !fraction(bush_removal_fraction) ||
      new_structures < 0 || !(foliage_scale_min > 0 && foliage_scale_max >= foliage_scale_min) ||
      !(foliage_density_min >= 0 && foliage_density_max >= foliage_density_min)) {
    throw std::invalid_argument(
        "fractions must be in [0, 1], new_structures not negative, and each foliage min "
        "positive and at most its max");
  }
}

DayChangeReport apply_day_changes(World& world, int64_t seed, const DayChangeConfig& config) {
  config.validate();
  Random rng(mix64(static_cast<uint64_t>(seed) * 7919 + 3));
  DayChangeReport report;
  std::vector<WorldObject> objects;
  const RoadNetwork& roads = world.roads();
  for (WorldObject o : world.objects()) {
    if (o.object_class == ObjectClass::kCar) {
      ++report.cars_total;
      if (rng.bernoulli(config.movable_change_fraction)) {
        if (rng.bernoulli(0.5)) {
          ++report.cars_removed;
          continue;
        }
        // Moved along its own axis, as a car re-parked further down the street.
        const double yaw = o.primitives.front().yaw_rad;
        const double shift = (rng.bernoulli(0.5) ? 1 : -1) * rng.uniform(5.0, 15.0);
        const Eigen::Vector2d delta = shift * Eigen::Vector2d(std::cos(yaw), std::sin(yaw));
        for (Primitive& p : o.primitives) {
          p.center.head<2>() += delta;
          p.center.z() += world.ground_height(p.center.x(), p.center.y()) -
                          world.ground_height(p.center.x() - delta.x(), p.center.y() - delta.y());
        }
        ++report.cars_moved;
      }
    } else if (o.object_class == ObjectClass::kBush &&
               rng.bernoulli(config.bush_removal_fraction)) {
      ++report.bushes_removed;
      continue;
    }
    bool foliage_changed = false;
    for (Primitive& p : o.primitives) {
      if (p.shape == Primitive::Shape::kFoliage) {
        p.half_size *= rng.uniform(config.foliage_scale_min, config.foliage_scale_max);
        p.density_per_m *=
            static_cast<float>(rng.uniform(config.foliage_density_min, config.foliage_density_max));
        foliage_changed = true;
      }
    }
    report.foliage_changed += foliage_changed ? 1 : 0;
    objects.push_back(std::move(o));
  }
  // New structures off the roads: containers, kiosks, fences.
  const Eigen::AlignedBox2d& b = world.bounds();
  uint32_t next_id = 0;
  for (const WorldObject& o : objects) {
    next_id = std::max(next_id, o.id + 1);
  }
  int attempts = 0;
  while (report.structures_added < config.new_structures && attempts++ < 10000) {
    const Eigen::Vector2d p(rng.uniform(b.min().x(), b.max().x()),
                            rng.uniform(b.min().y(), b.max().y()));
    const Eigen::Vector3d at(p.x(), p.y(), world.ground_height(p.x(), p.y()) + 1.0);
    if (roads.distance_to_road(p) < 0.5 * roads.road_width_m() + 3.0 ||
        world.distance_to_objects(at, 8.0) < 4.0) {
      continue;
    }
    WorldObject s;
    s.id = next_id++;
    s.object_class = ObjectClass::kStructure;
    const double z = world.ground_height(p.x(), p.y());
    const double yaw = rng.uniform(0, M_PI);
    const double kind = rng.uniform();
    Eigen::Vector3d size = kind < 0.4   ? Eigen::Vector3d(6.0, 2.4, 2.6)    // container
                           : kind < 0.7 ? Eigen::Vector3d(3.0, 3.0, 3.0)    // kiosk
                                        : Eigen::Vector3d(10.0, 0.1, 2.0);  // fence
    s.primitives.push_back(box(Eigen::Vector3d(p.x(), p.y(), z + 0.5 * size.z() - 0.1), size, yaw,
                               kind < 0.4 ? kMetal : kFacade));
    objects.push_back(std::move(s));
    ++report.structures_added;
  }
  world.set_objects(std::move(objects));
  return report;
}

}  // namespace liloc::sim
