#pragma once
// The polar descriptor of a keyframe (paper Eq. 3, after Scan Context): the cloud, in
// its body frame, cut into N_r rings x N_a sectors around the sensor; every cell keeps
// the maximum height of its points and their normal direction. Comparing two
// descriptors over every column shift gives their distance and the yaw between them
// (Eq. 4), which coarse-to-fine initialization and loop closure use.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "pointcloud/point_cloud.hpp"

namespace liloc {

struct PolarDescriptorConfig {
  int rings = 20;             // N_r (paper)
  int sectors = 60;           // N_a (paper)
  double max_range_m = 80.0;  // L_max: the outer ring's radius

  template <class V>
  void visit_fields(V& v) {
    v("rings", rings);
    v("sectors", sectors);
    v("max_range_m", max_range_m);
  }
  void validate() const;
};

struct PolarDescriptor {
  int rings = 0;
  int sectors = 0;
  // Cell (ring i, sector j) at index i * sectors + j. Empty cells: occupied = 0.
  std::vector<float> max_height_m;
  std::vector<Eigen::Vector3f> normals;  // unit, or zero where unknown
  std::vector<unsigned char> occupied;
};

// Eq. 3. Ring i holds ranges rho = |(x, y)| in [i, i + 1) * max_range_m / rings, sector j
// azimuths atan2(y, x) in [j, j + 1) * 2 pi / sectors (counter-clockwise from +x).
// Heights are z in the cloud's frame, i.e. relative to the sensor; points beyond
// max_range_m or not finite are ignored; cells without a point stay unoccupied (height 0,
// normal zero).
//
// Normals (in the cloud's frame, z > 0): those of the max-height surface, the cells'
// heights seen as a 2.5D elevation map, from its slope across the neighbouring cells
// (central differences, one-sided next to an empty cell, flat where both are empty).
// Not from the covariance of a cell's own points: cells are metres wide and mix ground
// with walls or crowns in proportions that change with the viewpoint, and beyond ~20 m a
// sparse sensor puts one ring into a cell, whose points lie on a line and have no normal.
// The max-height surface is what Eq. 3 describes; its slope is defined for every cell,
// changes smoothly with the viewpoint and says where the skyline rises (a wall facing
// the sensor tilts its cell's normal towards it).
//
// For descriptors that compare across slopes, use make_level_polar_descriptor: in the
// body's own frame a 3 deg pitch moves a cell 40 m away by 2 m.
PolarDescriptor make_polar_descriptor(const PointCloud& cloud_body,
                                      const PolarDescriptorConfig& config);

// The descriptor of the cloud levelled: rotated by the body's roll and pitch in
// R_world_body (world: any gravity-aligned frame, map or odom), its yaw kept, so that
// heights are along gravity and sectors still start at the body's heading. Descriptors
// meant to be compared (stored keyframes, a query) should all be made this way.
PolarDescriptor make_level_polar_descriptor(const PointCloud& cloud_body,
                                            const Eigen::Matrix3d& R_world_body,
                                            const PolarDescriptorConfig& config);

// Eq. 4 (the "XOR" of two descriptors: Scan Context's column-wise distance, minimized over
// column shifts), with heights and normals.
//
// Column j of a descriptor is the vector, over its rings i, of
//   (h_ij - floor, n_ij) for an occupied cell, (0, 0, 0, 0) for an empty one,
// where floor is the 5th percentile of the descriptor's occupied heights (the ground for
// a sensor on a vehicle; heights below it count as 0) and n_ij the cell's normal in its
// own polar frame (radial, tangential, up), so that shifting columns compares normals as
// a rotation of the sensor would. A normal weighs as 1 m of height: in tall cells the
// height leads, in low ones the normals say which rings are occupied and how the ground
// slopes. For a shift s, query column j faces candidate column (j + s) mod N_a and
//   distance(s) = 1 - mean over the column pairs where both are non-empty of
//                 max(0, cos(angle between the two column vectors)),
// in [0, 1]; 1 if no pair is non-empty on both sides (nothing supports a match). The
// result is the shift with the smallest distance (ties: the smallest |s|, then the
// positive one). On simulated VLP-16 keyframes: the same place within 5 m, up to ~0.35;
// places 50 m and more apart, from ~0.6.
//
// Yaw convention: yaw_rad = sector_shift * 2 pi / N_a, with sector_shift in
// (-N_a / 2, N_a / 2], is the yaw of R_candidate_query: the rotation taking the
// candidate's body axes onto the query's, i.e. p_candidate = Rz(yaw_rad) p_query for a
// point seen from the same place. A cloud rotated by +a (p_query = Rz(a) p_candidate)
// gives yaw_rad = -a.
//
// Throws std::invalid_argument if the two have different dimensions.
struct DescriptorMatch {
  double distance = 1.0;  // 0 = identical .. 1
  int sector_shift = 0;
  double yaw_rad = 0.0;
};
DescriptorMatch compare(const PolarDescriptor& query, const PolarDescriptor& candidate);

// Rotation-invariant summary for pre-selection (Scan Context's ring key): per ring, the
// fraction of its sectors that are occupied. Compare ring keys by Euclidean distance.
std::vector<float> ring_key(const PolarDescriptor& descriptor);

// Compact storage, little-endian:
//   "LPD1", uint16 rings, uint16 sectors,
//   occupancy bits (cell k is bit k % 8 of byte k / 8; unused bits zero),
//   per occupied cell in index order: float32 height, int8 x 3 normal (x 127, rounded).
// Unoccupied cells store nothing. Decoded normals are renormalized (quantization error
// below 0.5 deg).
std::vector<uint8_t> encode(const PolarDescriptor& descriptor);
// Throws std::invalid_argument naming the problem for truncated or corrupt bytes (wrong
// magic, bad dimensions, truncated bits or cells, set padding bits, non-finite heights,
// zero normals, trailing bytes).
PolarDescriptor decode_descriptor(const uint8_t* data, size_t size);

}  // namespace liloc
