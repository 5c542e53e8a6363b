#include "sim/session_simulator.hpp"

#include <algorithm>
#include <cmath>
#include <thread>

#include "sim/random.hpp"

namespace liloc::sim {

SessionSimulator::SessionSimulator(const World& world, const VehicleTrajectory& trajectory,
                                   LidarSpec lidar, SensorRig rig, ImuConfig imu, uint64_t seed,
                                   int64_t start_utime)
    : world_(world),
      trajectory_(trajectory),
      lidar_(std::move(lidar)),
      rig_(rig),
      beam_errors_(draw_beam_errors(lidar_, rig_.beam_errors)),
      imu_(imu),
      seed_(seed),
      start_utime_(start_utime) {
  const ImuSimulator probe(trajectory_, imu_, mix64(seed_ + 1), start_utime_);
  initial_accel_bias_ = probe.initial_accel_bias();
  initial_gyro_bias_ = probe.initial_gyro_bias();
}

int64_t SessionSimulator::num_sweeps() const {
  return static_cast<int64_t>(std::floor(trajectory_.duration_s() / lidar_.scan_period_s));
}

LidarScan SessionSimulator::simulate_sweep(int64_t index, RaycastScratch& scratch) const {
  const double t0 = index * lidar_.scan_period_s;
  LidarScan scan;
  scan.utime_us =
      start_utime_ + static_cast<int64_t>(std::llround((t0 + rig_.lidar_time_offset_s) * 1e6));
  scan.scan_period_s = static_cast<float>(lidar_.scan_period_s);
  const std::vector<LidarRay> rays = sweep_rays(lidar_, index);
  scan.points.reserve(rays.size());
  Random rng(hash_combine(seed_, static_cast<uint64_t>(index)));
  float pose_time = -1.0f;
  Eigen::Isometry3d T_world_lidar = Eigen::Isometry3d::Identity();
  for (size_t i = 0; i < rays.size(); ++i) {
    const LidarRay& ray = rays[i];
    if (ray.time_offset_s != pose_time) {
      // Rays fired together share a pose; every firing time gets its own (distortion).
      pose_time = ray.time_offset_s;
      T_world_lidar = trajectory_.pose(t0 + ray.time_offset_s) * rig_.T_body_lidar;
    }
    // The beam fires where its unit's calibration error turns it; the point is reported
    // along the nominal direction, as a driver with the nominal calibration would.
    const Eigen::Vector3d nominal = ray.direction.cast<double>();
    const BeamError* beam_error = beam_errors_.empty() ? nullptr : &beam_errors_[ray.ring];
    const Eigen::Vector3d dir =
        T_world_lidar.linear() * (beam_error ? beam_error->true_direction(nominal) : nominal);
    // Draw the noise for every ray, hit or not, so that a sweep's draws do not depend on
    // what it hits.
    const double noise = rng.normal(0.0, lidar_.range_noise_m);
    const double u_drop = rng.uniform();
    const double u_intensity = rng.uniform();
    const auto hit = world_.raycast(T_world_lidar.translation(), dir, lidar_.max_range_m, scratch);
    if (!hit || hit->range_m < lidar_.min_range_m) {
      continue;
    }
    // Weak returns fade beyond half the rated range, faster on dark surfaces.
    const double far =
        std::max(0.0, (hit->range_m - 0.5 * lidar_.max_range_m) / (0.5 * lidar_.max_range_m));
    const double p_lost = lidar_.dropout_probability + 0.7 * far * far * (1.0 - hit->reflectivity);
    if (u_drop < p_lost) {
      continue;
    }
    const double range = hit->range_m + noise + (beam_error ? beam_error->range_bias_m : 0.0);
    const double cos_incidence = std::abs(hit->normal.dot(dir));
    LidarPoint p;
    p.position_m = (nominal * range).cast<float>();
    p.intensity = static_cast<float>(std::min(
        255.0, 255.0 * hit->reflectivity * std::sqrt(cos_incidence) * (0.95 + 0.1 * u_intensity)));
    p.time_offset_s = ray.time_offset_s;
    p.ring = ray.ring;
    scan.points.push_back(p);
  }
  return scan;
}

SessionStats SessionSimulator::run(const std::function<void(const ImuSample&)>& on_imu,
                                   const std::function<void(const LidarScan&)>& on_scan,
                                   const std::function<void(double)>& progress, int threads) const {
  threads = std::max(1, threads);
  ImuSimulator imu(trajectory_, imu_, mix64(seed_ + 1), start_utime_);
  SessionStats stats;
  const int64_t sweeps = num_sweeps();
  const int64_t imu_end_utime =
      start_utime_ + static_cast<int64_t>(std::llround(trajectory_.duration_s() * 1e6));
  std::vector<RaycastScratch> scratch(threads);
  const int64_t batch = 8 * threads;
  std::vector<LidarScan> results(batch);
  const int64_t period_us = static_cast<int64_t>(std::llround(lidar_.scan_period_s * 1e6));
  ImuSample pending = imu.next();
  for (int64_t first = 0; first < sweeps; first += batch) {
    const int64_t count = std::min(batch, sweeps - first);
    std::vector<std::thread> workers;
    for (int w = 0; w < threads; ++w) {
      workers.emplace_back([&, w] {
        for (int64_t k = w; k < count; k += threads) {
          results[k] = simulate_sweep(first + k, scratch[w]);
        }
      });
    }
    for (std::thread& t : workers) {
      t.join();
    }
    for (int64_t k = 0; k < count; ++k) {
      const int64_t available_utime = results[k].utime_us + period_us;
      while (pending.utime_us <= available_utime) {
        on_imu(pending);
        ++stats.imu_samples;
        pending = imu.next();
      }
      stats.points += static_cast<int64_t>(results[k].points.size());
      on_scan(results[k]);
      ++stats.sweeps;
    }
    progress(static_cast<double>(first + count) / sweeps);
  }
  while (pending.utime_us <= imu_end_utime) {
    on_imu(pending);
    ++stats.imu_samples;
    pending = imu.next();
  }
  return stats;
}

Trajectory SessionSimulator::ground_truth(double rate_hz) const {
  std::vector<StampedPose> poses;
  const int64_t n = static_cast<int64_t>(std::floor(trajectory_.duration_s() * rate_hz));
  poses.reserve(static_cast<size_t>(n + 1));
  for (int64_t k = 0; k <= n; ++k) {
    const double t = k / rate_hz;
    poses.push_back({start_utime_ * 1e-6 + t, trajectory_.pose(t)});
  }
  return Trajectory(std::move(poses));
}

}  // namespace liloc::sim
