#include "sim/lidar_model.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "sim/random.hpp"

namespace liloc::sim {
namespace {
constexpr double kDeg = M_PI / 180.0;

std::vector<double> uniform_elevations(double lo_deg, double hi_deg, int rings) {
  std::vector<double> e(rings);
  for (int i = 0; i < rings; ++i) {
    e[i] = (lo_deg + (hi_deg - lo_deg) * i / (rings - 1)) * kDeg;
  }
  return e;
}
}  // namespace

std::vector<std::string> lidar_models() { return {"vlp16", "hdl32", "os1_64", "mid360"}; }

LidarSpec lidar_spec(const std::string& model) {
  LidarSpec s;
  s.name = model;
  if (model == "vlp16") {
    // Velodyne VLP-16: 16 beams over +-15 deg, 0.2 deg azimuth steps at 10 Hz, 100 m.
    s.elevations_rad = uniform_elevations(-15.0, 15.0, 16);
    s.columns = 1800;
    s.max_range_m = 100.0;
    s.range_noise_m = 0.03;
  } else if (model == "hdl32") {
    // Velodyne HDL-32E (the NCLT sensor): 32 beams from -30.67 to +10.67 deg,
    // 2170 firing cycles per 10 Hz revolution, 100 m.
    s.elevations_rad = uniform_elevations(-30.67, 10.67, 32);
    s.columns = 2170;
    s.max_range_m = 100.0;
    s.range_noise_m = 0.02;
  } else if (model == "os1_64") {
    // Ouster OS1-64: 64 beams over +-16.6 deg, 1024 columns at 10 Hz, 120 m.
    s.elevations_rad = uniform_elevations(-16.6, 16.6, 64);
    s.columns = 1024;
    s.max_range_m = 120.0;
    s.range_noise_m = 0.015;
  } else if (model == "mid360") {
    // Livox Mid-360: 200k points/s in a non-repetitive pattern over 360 x (-7, +52) deg,
    // 70 m (40 m at 10 % reflectivity), 4 beams.
    s.points_per_sweep = 20000;
    s.lasers = 4;
    s.min_elevation_rad = -7.0 * kDeg;
    s.max_elevation_rad = 52.0 * kDeg;
    s.min_range_m = 0.1;
    s.max_range_m = 70.0;
    s.range_noise_m = 0.02;
  } else {
    std::string known;
    for (const std::string& m : lidar_models()) {
      known += " " + m;
    }
    throw std::invalid_argument("unknown LiDAR model '" + model + "' (known:" + known + ")");
  }
  return s;
}

Eigen::Vector3d BeamError::true_direction(const Eigen::Vector3d& nominal) const {
  const double elevation = std::asin(std::clamp(nominal.z(), -1.0, 1.0)) + elevation_rad;
  const double azimuth = std::atan2(nominal.y(), nominal.x()) + azimuth_rad;
  return Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                         std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
}

std::vector<BeamError> draw_beam_errors(const LidarSpec& spec, const BeamErrorSigmas& sigmas) {
  if (!sigmas.any()) {
    return {};
  }
  const int beams = spec.spinning() ? static_cast<int>(spec.elevations_rad.size()) : spec.lasers;
  Random rng(mix64(sigmas.seed));
  std::vector<BeamError> errors(static_cast<size_t>(beams));
  for (BeamError& e : errors) {
    e.range_bias_m = rng.normal(0.0, sigmas.range_bias_m);
    e.elevation_rad = rng.normal(0.0, sigmas.elevation_rad);
    e.azimuth_rad = rng.normal(0.0, sigmas.azimuth_rad);
  }
  return errors;
}

std::vector<LidarRay> sweep_rays(const LidarSpec& spec, int64_t sweep_index) {
  std::vector<LidarRay> rays;
  rays.reserve(static_cast<size_t>(spec.rays_per_sweep()));
  if (spec.spinning()) {
    const int rings = static_cast<int>(spec.elevations_rad.size());
    for (int c = 0; c < spec.columns; ++c) {
      // Velodyne-style: clockwise seen from above, starting behind the sensor.
      const double azimuth = M_PI - 2.0 * M_PI * c / spec.columns;
      const float t = static_cast<float>(spec.scan_period_s * c / spec.columns);
      for (int r = 0; r < rings; ++r) {
        const double el = spec.elevations_rad[r];
        rays.push_back({Eigen::Vector3f(std::cos(el) * std::cos(azimuth),
                                        std::cos(el) * std::sin(azimuth), std::sin(el)),
                        t, static_cast<uint8_t>(r)});
      }
    }
    return rays;
  }
  // Rosette-like: each beam's elevation follows a triangle wave whose frequency is
  // incommensurate with the rotation, so successive sweeps fill different gaps.
  const double rate_hz = spec.points_per_sweep / spec.scan_period_s;
  const double rotation_hz = 1.0 / spec.scan_period_s;
  const double oscillation_hz = 1373.0 * (1.0 + (std::sqrt(5.0) - 1.0) / 2000.0);
  const double mid = 0.5 * (spec.min_elevation_rad + spec.max_elevation_rad);
  const double amp = 0.5 * (spec.max_elevation_rad - spec.min_elevation_rad);
  for (int i = 0; i < spec.points_per_sweep; ++i) {
    const int laser = i % spec.lasers;
    const double t_global =
        (static_cast<double>(sweep_index) * spec.points_per_sweep + i) / rate_hz;
    const double phase = 2.0 * M_PI * (oscillation_hz * t_global + 0.25 * laser);
    const double el = mid + amp * (2.0 / M_PI) * std::asin(std::sin(phase));
    const double az = 2.0 * M_PI * (rotation_hz * t_global + 0.25 * laser + 0.013 * sweep_index);
    rays.push_back(
        {Eigen::Vector3f(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)),
         static_cast<float>(i / rate_hz), static_cast<uint8_t>(laser)});
  }
  return rays;
}

}  // namespace liloc::sim
