#pragma once
// The simulated world: a ground heightfield, solid primitives (oriented boxes, vertical
// cylinders) and foliage volumes that return scattered hits, indexed by a 2D grid for
// fast ray casting. Built by world_generator.hpp; sessions drive on its road network.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <vector>

#include "sim/road_network.hpp"

namespace liloc::sim {

enum class ObjectClass : uint8_t {
  kBuilding,
  kWall,
  kCurb,
  kCar,
  kTree,
  kBush,
  kPole,
  kStructure,  // kiosks, containers, fences: what appears between sessions
  kTunnel,
};

// One geometric piece of an object, in the world frame.
struct Primitive {
  enum class Shape : uint8_t { kBox, kCylinder, kFoliage };
  Shape shape = Shape::kBox;
  uint32_t object_id = 0;
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  // Box: half extents along its own (yawed) axes. Cylinder (vertical): (radius, radius,
  // half height). Foliage: radii of the ellipsoid.
  Eigen::Vector3d half_size = Eigen::Vector3d::Ones();
  double yaw_rad = 0.0;        // boxes only
  float reflectivity = 0.3f;   // 0..1, scales the returned intensity
  float density_per_m = 0.0f;  // foliage: expected leaf hits per metre of ray inside
};

struct WorldObject {
  uint32_t id = 0;
  ObjectClass object_class = ObjectClass::kBuilding;
  bool movable = false;  // cars: may move or vanish between sessions
  std::vector<Primitive> primitives;
};

// Terrain as heights on a regular grid; each cell is split into two triangles along its
// (0,0)-(1,1) diagonal, so that height_at() and ray casting see the same surface.
struct Heightfield {
  double origin_x_m = 0.0;
  double origin_y_m = 0.0;
  double resolution_m = 1.0;
  int nx = 0;  // vertices along x
  int ny = 0;
  std::vector<float> heights_m;     // nx * ny, index x + nx * y
  std::vector<float> reflectivity;  // per cell, (nx-1) * (ny-1)

  float vertex(int ix, int iy) const { return heights_m[ix + nx * iy]; }
  // Height of the triangulated surface; clamps to the grid's border outside it.
  double height_at(double x, double y) const;
};

struct RayHit {
  double range_m = 0.0;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit, facing the ray
  float reflectivity = 0.0f;
  uint32_t object_id = 0;  // kGroundId for the terrain
};

// Per-thread working memory for ray casting (avoids testing a primitive twice per ray).
struct RaycastScratch {
  std::vector<uint32_t> last_ray;
  uint32_t ray_counter = 0;
};

class World {
 public:
  static constexpr uint32_t kGroundId = 0xffffffffu;

  World(Heightfield ground, std::vector<WorldObject> objects, RoadNetwork roads,
        Eigen::AlignedBox2d bounds, double grid_cell_m);

  // First surface along origin + t * direction (direction unit length) with
  // 0 < t <= max_range_m.
  std::optional<RayHit> raycast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                                double max_range_m, RaycastScratch& scratch) const;

  // Distance from p to the nearest surface (0 inside foliage), for checking simulated
  // scans; considers primitives within search_radius_m.
  double distance_to_surface(const Eigen::Vector3d& p, double search_radius_m = 4.0) const;
  // The same, objects only (no terrain); infinity if none within search_radius_m.
  double distance_to_objects(const Eigen::Vector3d& p, double search_radius_m) const;

  double ground_height(double x, double y) const { return ground_.height_at(x, y); }

  const std::vector<WorldObject>& objects() const { return objects_; }
  const RoadNetwork& roads() const { return roads_; }
  const Eigen::AlignedBox2d& bounds() const { return bounds_; }
  const Heightfield& ground() const { return ground_; }
  size_t num_primitives() const { return primitives_.size(); }

  // Replaces the objects (between sessions) and rebuilds the index.
  void set_objects(std::vector<WorldObject> objects);

 private:
  void build_index();
  bool ground_hit(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_max,
                  RayHit& hit) const;

  Heightfield ground_;
  std::vector<WorldObject> objects_;
  RoadNetwork roads_;
  Eigen::AlignedBox2d bounds_;
  double cell_m_;
  int cells_x_ = 0;
  int cells_y_ = 0;
  std::vector<Primitive> primitives_;
  std::vector<Eigen::Vector2d> yaw_cos_sin_;  // per primitive, for boxes
  // Grid of primitive indices in compressed rows: cell c owns
  // cell_items_[cell_start_[c] .. cell_start_[c + 1]).
  std::vector<uint32_t> cell_start_;
  std::vector<uint32_t> cell_items_;
  float ground_max_m_ = 0.0f;
};

}  // namespace liloc::sim
