#pragma once
// Beam patterns of the simulated LiDARs: spinning multi-beam sensors (VLP-16, HDL-32E as
// in NCLT, OS1-64) and a non-repetitive Livox Mid-360-like pattern.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace liloc::sim {

struct LidarSpec {
  std::string name;
  double scan_period_s = 0.1;
  double min_range_m = 0.5;
  double max_range_m = 100.0;
  double range_noise_m = 0.02;        // 1 sigma
  double dropout_probability = 0.01;  // returns lost at random
  // Spinning sensors: one ring per elevation, `columns` firings per sweep.
  std::vector<double> elevations_rad;
  int columns = 0;
  // Non-repetitive sensors: points_per_sweep returns from `lasers` beams sweeping an
  // elevation band [min, max] while the head rotates; the pattern never repeats.
  int points_per_sweep = 0;
  int lasers = 0;
  double min_elevation_rad = 0.0;
  double max_elevation_rad = 0.0;

  bool spinning() const { return columns > 0; }
  int rays_per_sweep() const {
    return spinning() ? columns * static_cast<int>(elevations_rad.size()) : points_per_sweep;
  }
};

// "vlp16", "hdl32", "os1_64" or "mid360"; throws std::invalid_argument naming the
// model and the known ones otherwise.
LidarSpec lidar_spec(const std::string& model);
std::vector<std::string> lidar_models();

struct LidarRay {
  Eigen::Vector3f direction;  // unit, lidar frame
  float time_offset_s;        // after the sweep start
  uint8_t ring;
};

// A unit's intrinsic calibration error: each beam fires at an elevation and azimuth off
// the nominal ones its driver reports, and its ranges carry a bias. Real units keep such
// errors after factory calibration (centimetres, tenths of a degree); they make a point's
// error depend on the viewpoint, so registration against a map stops being exact.
struct BeamErrorSigmas {
  double range_bias_m = 0.0;
  double elevation_rad = 0.0;
  double azimuth_rad = 0.0;
  uint64_t seed = 1;  // the unit: every session of one sensor shares its errors

  bool any() const { return range_bias_m > 0 || elevation_rad > 0 || azimuth_rad > 0; }
};

struct BeamError {
  double range_bias_m = 0.0;
  double elevation_rad = 0.0;
  double azimuth_rad = 0.0;

  // The direction the beam really fires in, for the nominal unit direction `nominal`.
  Eigen::Vector3d true_direction(const Eigen::Vector3d& nominal) const;
};

// One error per beam (a ring of a spinning sensor, a laser of the non-repetitive one);
// empty when every sigma is zero.
std::vector<BeamError> draw_beam_errors(const LidarSpec& spec, const BeamErrorSigmas& sigmas);

// The rays of sweep number `sweep_index` in firing order. Spinning sensors repeat every
// sweep; the non-repetitive pattern depends on the index.
std::vector<LidarRay> sweep_rays(const LidarSpec& spec, int64_t sweep_index);

}  // namespace liloc::sim
