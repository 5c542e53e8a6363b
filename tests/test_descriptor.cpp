#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "descriptor/polar_descriptor.hpp"

namespace liloc {
namespace {

constexpr double kPi = 3.141592653589793;
constexpr double kDeg = kPi / 180.0;

// Synthetic places: boxes (buildings, kiosks) and poles standing on flat ground, sampled
// on their surfaces. The sensor is 1.2 m above the ground and sees it around itself
// from 5 m (its lowest beam's reach) to 40 m, objects to 80 m: what a spinning LiDAR
// roughly delivers.
struct Box {
  Eigen::Vector2d center;
  Eigen::Vector2d half;  // along the box's own axes
  double height_m;
  double yaw_rad;
};
struct Pole {
  Eigen::Vector2d center;
  double radius_m;
  double height_m;
};
struct Scene {
  std::vector<Box> boxes;
  std::vector<Pole> poles;
};

constexpr double kGroundZ = -1.2;
constexpr double kSpacing = 0.4;

// Deterministic numbers in [0, 1) (SplitMix64), the same on every platform.
class Sequence {
 public:
  explicit Sequence(uint64_t seed) : state_(seed) {}
  double next() {
    state_ += 0x9e3779b97f4a7c15ULL;
    uint64_t x = state_;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
    return static_cast<double>((x ^ (x >> 31)) >> 11) * 0x1.0p-53;
  }
  double uniform(double lo, double hi) { return lo + (hi - lo) * next(); }

 private:
  uint64_t state_;
};

// A street along x: rows of buildings with gaps on both sides, poles along the curbs.
Scene street(uint64_t seed) {
  Sequence r(seed);
  Scene s;
  for (int side = -1; side <= 1; side += 2) {
    double x = -90.0 + r.uniform(0.0, 10.0);
    while (x < 90.0) {
      const double length = r.uniform(8.0, 25.0);
      const double depth = r.uniform(8.0, 15.0);
      s.boxes.push_back(
          {Eigen::Vector2d(x + length / 2, side * (r.uniform(10.0, 14.0) + depth / 2)),
           Eigen::Vector2d(length / 2, depth / 2), r.uniform(4.0, 18.0), 0.0});
      x += length + r.uniform(3.0, 12.0);
    }
    for (double px = -80.0 + r.uniform(0.0, 15.0); px < 80.0; px += r.uniform(12.0, 25.0)) {
      s.poles.push_back({Eigen::Vector2d(px, side * 7.0), 0.15, 6.0});
    }
  }
  return s;
}

// An open square: a few scattered buildings and kiosks at random orientations.
Scene square(uint64_t seed) {
  Sequence r(seed);
  Scene s;
  for (int i = 0; i < 12; ++i) {
    const double angle = r.uniform(0.0, 2.0 * kPi);
    const double range = r.uniform(15.0, 70.0);
    s.boxes.push_back({Eigen::Vector2d(range * std::cos(angle), range * std::sin(angle)),
                       Eigen::Vector2d(r.uniform(2.0, 12.0), r.uniform(2.0, 12.0)),
                       r.uniform(3.0, 20.0), r.uniform(0.0, kPi)});
  }
  return s;
}

// The scene's surfaces seen from (x, y, yaw), in the sensor frame.
PointCloud observe(const Scene& scene, double x, double y, double yaw) {
  std::vector<Eigen::Vector3d> world;
  for (double gx = -40.0; gx <= 40.0; gx += kSpacing) {
    for (double gy = -40.0; gy <= 40.0; gy += kSpacing) {
      const double r2 = gx * gx + gy * gy;
      if (r2 >= 5.0 * 5.0 && r2 <= 39.9 * 39.9) {  // not on a ring boundary
        world.emplace_back(x + gx, y + gy, kGroundZ);
      }
    }
  }
  for (const Box& b : scene.boxes) {
    const Eigen::Rotation2Dd R(b.yaw_rad);
    const auto add = [&](const Eigen::Vector2d& local, double z) {
      const Eigen::Vector2d p = b.center + R * local;
      world.emplace_back(p.x(), p.y(), z);
    };
    for (double z = kGroundZ; z <= kGroundZ + b.height_m; z += kSpacing) {
      for (double u = -b.half.x(); u <= b.half.x(); u += kSpacing) {
        add(Eigen::Vector2d(u, -b.half.y()), z);
        add(Eigen::Vector2d(u, b.half.y()), z);
      }
      for (double v = -b.half.y(); v <= b.half.y(); v += kSpacing) {
        add(Eigen::Vector2d(-b.half.x(), v), z);
        add(Eigen::Vector2d(b.half.x(), v), z);
      }
    }
    for (double u = -b.half.x(); u <= b.half.x(); u += kSpacing) {
      for (double v = -b.half.y(); v <= b.half.y(); v += kSpacing) {
        add(Eigen::Vector2d(u, v), kGroundZ + b.height_m);
      }
    }
  }
  for (const Pole& p : scene.poles) {
    for (double z = kGroundZ; z <= kGroundZ + p.height_m; z += kSpacing / 2) {
      for (int k = 0; k < 8; ++k) {
        world.emplace_back(p.center.x() + p.radius_m * std::cos(k * kPi / 4),
                           p.center.y() + p.radius_m * std::sin(k * kPi / 4), z);
      }
    }
  }
  const Eigen::Isometry3d T_world_sensor =
      Eigen::Translation3d(x, y, 0.0) * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ());
  const Eigen::Isometry3d T_sensor_world = T_world_sensor.inverse();
  PointCloud cloud;
  for (const Eigen::Vector3d& w : world) {
    cloud.push_back((T_sensor_world * w).cast<float>(), 0.0f);
  }
  return cloud;
}

PointCloud rotated(const PointCloud& cloud, double yaw) {
  const Eigen::Matrix3f R =
      Eigen::AngleAxisf(static_cast<float>(yaw), Eigen::Vector3f::UnitZ()).toRotationMatrix();
  PointCloud out;
  for (const Eigen::Vector3f& p : cloud.points) {
    out.push_back(R * p, 0.0f);
  }
  return out;
}

size_t cell(const PolarDescriptor& d, int ring, int sector) {
  return static_cast<size_t>(ring) * d.sectors + sector;
}

int count_occupied(const PolarDescriptor& d) {
  int n = 0;
  for (unsigned char o : d.occupied) {
    n += o;
  }
  return n;
}

// Eq. 3's binning: 4 m rings (80 m / 20), 6 deg sectors counter-clockwise from +x, the
// maximum height per cell; far and non-finite points are ignored.
TEST(PolarDescriptor, CellsHoldTheMaxHeightOfTheirPoints) {
  PointCloud cloud;
  cloud.push_back({10.0f, 0.5f, 1.0f}, 0.0f);    // ring 2, sector 0
  cloud.push_back({10.5f, 0.2f, 2.5f}, 0.0f);    // same cell, higher
  cloud.push_back({11.0f, 0.3f, -0.5f}, 0.0f);   // same cell, lower
  cloud.push_back({0.5f, 30.0f, -1.0f}, 0.0f);   // ring 7, sector 14 (89 deg)
  cloud.push_back({-0.5f, 30.0f, 4.0f}, 0.0f);   // ring 7, sector 15 (91 deg)
  cloud.push_back({5.0f, -0.1f, 0.5f}, 0.0f);    // ring 1, sector 59 (just below 360 deg)
  cloud.push_back({79.0f, -20.0f, 1.0f}, 0.0f);  // beyond 80 m
  cloud.push_back({NAN, 1.0f, 1.0f}, 0.0f);
  const PolarDescriptor d = make_polar_descriptor(cloud, PolarDescriptorConfig{});
  ASSERT_EQ(d.rings, 20);
  ASSERT_EQ(d.sectors, 60);
  ASSERT_EQ(d.max_height_m.size(), 1200u);
  EXPECT_EQ(count_occupied(d), 4);
  EXPECT_TRUE(d.occupied[cell(d, 2, 0)]);
  EXPECT_FLOAT_EQ(d.max_height_m[cell(d, 2, 0)], 2.5f);
  EXPECT_TRUE(d.occupied[cell(d, 7, 14)]);
  EXPECT_FLOAT_EQ(d.max_height_m[cell(d, 7, 14)], -1.0f);
  EXPECT_TRUE(d.occupied[cell(d, 7, 15)]);
  EXPECT_FLOAT_EQ(d.max_height_m[cell(d, 7, 15)], 4.0f);
  EXPECT_TRUE(d.occupied[cell(d, 1, 59)]);
  for (size_t k = 0; k < d.occupied.size(); ++k) {
    if (d.occupied[k]) {
      EXPECT_NEAR(d.normals[k].norm(), 1.0f, 1e-5f);
      EXPECT_GT(d.normals[k].z(), 0.0f);
    } else {
      EXPECT_EQ(d.max_height_m[k], 0.0f);
      EXPECT_TRUE(d.normals[k].isZero());
    }
  }
  // Ring 7 rises by 5 m from sector 14 to 15 (over 3 m of arc): the normal of sector 14
  // leans away from the rise, towards -tangential, which at 87 deg is +x.
  EXPECT_GT(d.normals[cell(d, 7, 14)].x(), 0.5f);
}

// Normals of the max-height surface: up on flat ground, the plane's normal on a ramp,
// and tilted towards the sensor in front of a wall.
TEST(PolarDescriptor, NormalsFollowTheMaxHeightSurface) {
  // Ground to 60 m; with `shadow`, not behind the wall below (what a LiDAR sees).
  const auto ground = [](double slope_x, bool shadow) {
    PointCloud cloud;
    for (double x = -60.0; x <= 60.0; x += 0.25) {
      for (double y = -60.0; y <= 60.0; y += 0.25) {
        if (x * x + y * y >= 60.0 * 60.0 || (shadow && x > 21.0 && std::abs(y) < 10.0 * x / 21.0)) {
          continue;
        }
        cloud.push_back(Eigen::Vector3d(x, y, kGroundZ + slope_x * x).cast<float>(), 0.0f);
      }
    }
    return cloud;
  };
  const PolarDescriptor flat = make_polar_descriptor(ground(0.0, false), PolarDescriptorConfig{});
  EXPECT_EQ(count_occupied(flat), 15 * 60);  // rings 0 .. 14 (< 60 m) everywhere
  for (size_t k = 0; k < flat.occupied.size(); ++k) {
    if (flat.occupied[k]) {
      EXPECT_GT(flat.normals[k].z(), 0.9999f) << "cell " << k;
    }
  }

  // A 10 % ramp along x: the true normal is (-0.1, 0, 1) / |.|. Away from the centre
  // (where cells are narrower than the max-height sampling) and from the outer ring
  // (one-sided differences), every cell's normal is within 2 deg of it.
  const Eigen::Vector3f truth = Eigen::Vector3f(-0.1f, 0.0f, 1.0f).normalized();
  const PolarDescriptor ramp = make_polar_descriptor(ground(0.1, false), PolarDescriptorConfig{});
  double worst_deg = 0.0;
  for (int i = 3; i < 14; ++i) {
    for (int j = 0; j < ramp.sectors; ++j) {
      const Eigen::Vector3f& n = ramp.normals[cell(ramp, i, j)];
      worst_deg = std::max(worst_deg, std::acos(std::min(1.0f, n.dot(truth))) / kDeg);
    }
  }
  EXPECT_LT(worst_deg, 2.0);

  // A 6 m wall across x = 21 m, the ground behind it hidden: the surface rises from the
  // ground (ring 4) to the wall's top (ring 5), so the wall cell's normal leans back
  // towards the sensor (-x).
  PointCloud scene = ground(0.0, true);
  for (int iy = -50; iy <= 50; ++iy) {
    for (int iz = 0; iz <= 30; ++iz) {
      scene.push_back(Eigen::Vector3d(21.0, 0.2 * iy, kGroundZ + 0.2 * iz).cast<float>(), 0.0f);
    }
  }
  const PolarDescriptor wall = make_polar_descriptor(scene, PolarDescriptorConfig{});
  const Eigen::Vector3f& n_wall = wall.normals[cell(wall, 5, 0)];  // 20-24 m, 0-6 deg
  EXPECT_FLOAT_EQ(wall.max_height_m[cell(wall, 5, 0)], static_cast<float>(kGroundZ + 6.0));
  EXPECT_LT(n_wall.x(), -0.5f);
  EXPECT_GT(n_wall.z(), 0.0f);
}

// A body pitched and rolled on a slope: levelling by its attitude gives the descriptor of
// the level view at the same heading; without it, far cells move by metres.
TEST(PolarDescriptor, LevelDescriptorUndoesRollAndPitch) {
  const double heading = 30.0 * kDeg;
  const PointCloud level_cloud = observe(street(1), 0.0, 0.0, heading);
  const Eigen::Matrix3d R_tilt = (Eigen::AngleAxisd(4.0 * kDeg, Eigen::Vector3d::UnitY()) *
                                  Eigen::AngleAxisd(-3.0 * kDeg, Eigen::Vector3d::UnitX()))
                                     .toRotationMatrix();
  const Eigen::Matrix3d R_world_body =
      Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitZ()).toRotationMatrix() * R_tilt;
  PointCloud body_cloud;
  for (const Eigen::Vector3f& p : level_cloud.points) {
    body_cloud.push_back(R_tilt.transpose().cast<float>() * p, 0.0f);
  }
  const PolarDescriptorConfig config;
  const PolarDescriptor reference = make_polar_descriptor(level_cloud, config);
  const DescriptorMatch levelled =
      compare(make_level_polar_descriptor(body_cloud, R_world_body, config), reference);
  EXPECT_EQ(levelled.sector_shift, 0);
  EXPECT_LT(levelled.distance, 0.01);
  EXPECT_GT(compare(make_polar_descriptor(body_cloud, config), reference).distance,
            levelled.distance + 0.05);
}

TEST(PolarDescriptor, IdenticalCloudsMatchAtZeroShift) {
  const PointCloud cloud = observe(street(1), 0.0, 0.0, 0.0);
  const PolarDescriptor a = make_polar_descriptor(cloud, PolarDescriptorConfig{});
  const PolarDescriptor b = make_polar_descriptor(cloud, PolarDescriptorConfig{});
  const DescriptorMatch m = compare(a, b);
  EXPECT_LT(m.distance, 1e-9);
  EXPECT_EQ(m.sector_shift, 0);
  EXPECT_EQ(m.yaw_rad, 0.0);
  EXPECT_GT(count_occupied(a), 600);
}

// Convention: a query cloud rotated by +a against the candidate (p_query = Rz(a)
// p_candidate) gives yaw_rad = -a, the yaw of R_candidate_query.
TEST(PolarDescriptor, RotatedCloudGivesTheShiftAndYaw) {
  const PointCloud candidate_cloud = observe(square(2), 0.0, 0.0, 0.0);
  const PolarDescriptor candidate = make_polar_descriptor(candidate_cloud, PolarDescriptorConfig{});
  struct Case {
    double rotation_deg;
    int shift;
  };
  for (const Case c :
       {Case{36.0, -6}, Case{-36.0, 6}, Case{90.0, -15}, Case{180.0, 30}, Case{-150.0, 25}}) {
    const PolarDescriptor query = make_polar_descriptor(
        rotated(candidate_cloud, c.rotation_deg * kDeg), PolarDescriptorConfig{});
    const DescriptorMatch m = compare(query, candidate);
    EXPECT_EQ(m.sector_shift, c.shift) << c.rotation_deg << " deg";
    EXPECT_NEAR(m.yaw_rad, c.shift * 6.0 * kDeg, 1e-12);
    EXPECT_LT(m.distance, 0.01) << c.rotation_deg << " deg";
    // Swapping the roles inverts the rotation.
    EXPECT_EQ(compare(candidate, query).sector_shift, c.shift == 30 ? 30 : -c.shift);
  }
  // Between sectors: 20 deg is found as the nearest multiple of 6 deg, 18 deg.
  const DescriptorMatch m =
      compare(make_polar_descriptor(rotated(candidate_cloud, 20.0 * kDeg), PolarDescriptorConfig{}),
              candidate);
  EXPECT_EQ(m.sector_shift, -3);
  EXPECT_LT(m.distance, 0.15);
}

// Place recognition: the same place seen from a metre or two away (and turned) is
// closer than other places, streets of the same kind included.
TEST(PolarDescriptor, SamePlaceIsCloserThanAnotherPlace) {
  const PolarDescriptorConfig config;
  const PolarDescriptor here = make_polar_descriptor(observe(street(1), 0.0, 0.0, 0.0), config);
  const std::vector<PolarDescriptor> same = {
      make_polar_descriptor(observe(street(1), 1.0, 0.0, 0.0), config),
      make_polar_descriptor(observe(street(1), -1.5, 1.0, 0.0), config),
      make_polar_descriptor(observe(street(1), 2.0, -0.5, 24.0 * kDeg), config)};
  const std::vector<PolarDescriptor> other = {
      make_polar_descriptor(observe(street(2), 0.0, 0.0, 0.0), config),
      make_polar_descriptor(observe(street(3), 0.0, 0.0, 0.0), config),
      make_polar_descriptor(observe(street(1), 40.0, 0.0, 0.0), config),
      make_polar_descriptor(observe(square(4), 0.0, 0.0, 0.0), config)};
  double farthest_same = 0.0;
  for (const PolarDescriptor& d : same) {
    const DescriptorMatch m = compare(d, here);
    farthest_same = std::max(farthest_same, m.distance);
  }
  // The turned view: the sensor turned by +24 deg, R_candidate_query = Rz(+24 deg).
  EXPECT_EQ(compare(same[2], here).sector_shift, 4);
  double nearest_other = 1.0;
  for (const PolarDescriptor& d : other) {
    nearest_other = std::min(nearest_other, compare(d, here).distance);
  }
  EXPECT_LT(farthest_same, nearest_other - 0.05)
      << "same place up to " << farthest_same << ", other places from " << nearest_other;
}

TEST(PolarDescriptor, RingKeyIsRotationInvariantOccupancy) {
  const PointCloud cloud = observe(square(2), 0.0, 0.0, 0.0);
  const std::vector<float> key = ring_key(make_polar_descriptor(cloud, PolarDescriptorConfig{}));
  ASSERT_EQ(key.size(), 20u);
  // Ground from 5 to 40 m: rings 1 .. 9 are full.
  for (int i = 1; i < 10; ++i) {
    EXPECT_FLOAT_EQ(key[i], 1.0f);
  }
  const std::vector<float> turned =
      ring_key(make_polar_descriptor(rotated(cloud, 36.0 * kDeg), PolarDescriptorConfig{}));
  const std::vector<float> other =
      ring_key(make_polar_descriptor(observe(square(5), 0.0, 0.0, 0.0), PolarDescriptorConfig{}));
  double to_turned = 0.0, to_other = 0.0;
  for (size_t i = 0; i < key.size(); ++i) {
    to_turned += (key[i] - turned[i]) * (key[i] - turned[i]);
    to_other += (key[i] - other[i]) * (key[i] - other[i]);
  }
  EXPECT_LT(std::sqrt(to_turned), 0.02);
  EXPECT_GT(std::sqrt(to_other), 0.1);
}

TEST(PolarDescriptor, EncodeDecodeRoundTrip) {
  const PolarDescriptor d =
      make_polar_descriptor(observe(street(1), 0.0, 0.0, 0.0), PolarDescriptorConfig{});
  const int occupied = count_occupied(d);
  const std::vector<uint8_t> bytes = encode(d);
  EXPECT_EQ(bytes.size(), 8u + 150u + 7u * occupied);
  const PolarDescriptor back = decode_descriptor(bytes.data(), bytes.size());
  ASSERT_EQ(back.rings, d.rings);
  ASSERT_EQ(back.sectors, d.sectors);
  EXPECT_EQ(back.occupied, d.occupied);
  EXPECT_EQ(back.max_height_m, d.max_height_m);
  double worst_deg = 0.0;
  for (size_t k = 0; k < d.normals.size(); ++k) {
    if (d.occupied[k]) {
      EXPECT_NEAR(back.normals[k].norm(), 1.0f, 1e-5f);
      worst_deg =
          std::max(worst_deg, std::acos(std::min(1.0f, back.normals[k].dot(d.normals[k]))) / kDeg);
    } else {
      EXPECT_TRUE(back.normals[k].isZero());
    }
  }
  EXPECT_LT(worst_deg, 0.5);
  const DescriptorMatch m = compare(back, d);
  EXPECT_EQ(m.sector_shift, 0);
  EXPECT_LT(m.distance, 0.005);
}

void expect_rejected(const std::vector<uint8_t>& bytes, const std::string& what) {
  try {
    decode_descriptor(bytes.data(), bytes.size());
    ADD_FAILURE() << "accepted, expected: " << what;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
  }
}

TEST(PolarDescriptor, DecodeRejectsTruncatedAndCorruptBytes) {
  // 3 x 7 = 21 cells: the last occupancy byte has 3 padding bits.
  PolarDescriptorConfig small;
  small.rings = 3;
  small.sectors = 7;
  small.max_range_m = 30.0;
  PointCloud cloud;
  cloud.push_back({5.0f, 1.0f, 0.5f}, 0.0f);
  cloud.push_back({15.0f, -3.0f, 2.0f}, 0.0f);
  const std::vector<uint8_t> good = encode(make_polar_descriptor(cloud, small));
  ASSERT_EQ(good.size(), 8u + 3u + 2u * 7u);
  EXPECT_EQ(count_occupied(decode_descriptor(good.data(), good.size())), 2);

  expect_rejected({good.begin(), good.begin() + 5}, "truncated header");
  std::vector<uint8_t> bad = good;
  bad[0] = 'X';
  expect_rejected(bad, "wrong magic");
  bad = good;
  bad[4] = 0;  // rings = 0
  expect_rejected(bad, "rings must be");
  expect_rejected({good.begin(), good.begin() + 9}, "truncated occupancy bits");
  expect_rejected({good.begin(), good.end() - 1}, "truncated cells");
  bad = good;
  bad.push_back(0);
  expect_rejected(bad, "trailing bytes");
  bad = good;
  bad[10] |= 0x80;  // bit 23: beyond the 21 cells
  expect_rejected(bad, "padding bits");
  bad = good;
  bad[11] = bad[12] = 0x00;  // first cell's height: 0x7fc00000 = NaN
  bad[13] = 0xc0;
  bad[14] = 0x7f;
  expect_rejected(bad, "not finite");
  bad = good;
  bad[15] = bad[16] = bad[17] = 0;
  expect_rejected(bad, "normal of cell");
  // A flipped occupancy bit changes the cell count: the length no longer fits.
  bad = good;
  bad[8] ^= 0x01;
  EXPECT_THROW(decode_descriptor(bad.data(), bad.size()), std::invalid_argument);
}

TEST(PolarDescriptor, RejectsBadConfigurationsAndMismatchedSizes) {
  PolarDescriptorConfig c;
  c.rings = 0;
  EXPECT_THROW(c.validate(), std::invalid_argument);
  c = PolarDescriptorConfig{};
  c.max_range_m = 0.0;
  EXPECT_THROW(c.validate(), std::invalid_argument);
  EXPECT_THROW(make_polar_descriptor(PointCloud{}, c), std::invalid_argument);
  c = PolarDescriptorConfig{};
  c.sectors = 30;
  const PolarDescriptor coarse = make_polar_descriptor(PointCloud{}, c);
  const PolarDescriptor normal = make_polar_descriptor(PointCloud{}, PolarDescriptorConfig{});
  EXPECT_THROW(compare(coarse, normal), std::invalid_argument);
  // Nothing observed: no evidence for a match.
  EXPECT_EQ(compare(normal, normal).distance, 1.0);
}

}  // namespace
}  // namespace liloc
