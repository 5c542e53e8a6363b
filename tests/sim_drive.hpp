#pragma once
// A simulated drive for the tests of the factors and the optimizer: session A of the default
// campus (its length scaled), the vehicle's exact trajectory, and the simulator's IMU on it
// without noise, plus a constant bias.

#include <memory>
#include <vector>

#include "imu/imu_sample.hpp"
#include "sim/imu_simulator.hpp"
#include "sim/session_recipe.hpp"
#include "sim/simulation_config.hpp"
#include "sim/vehicle_trajectory.hpp"

namespace liloc::test {

struct NoiseFreeImuDrive {
  sim::SimulationConfig config;
  std::unique_ptr<sim::SimulatedSessions> sessions;
  std::unique_ptr<sim::VehicleTrajectory> trajectory;
  std::vector<ImuSample> imu;  // session time from 0
  double gravity_mps2 = 0.0;

  NoiseFreeImuDrive(double length_scale, const Eigen::Vector3d& accel_bias,
                    const Eigen::Vector3d& gyro_bias) {
    sim::scale_session_lengths(config.sessions, length_scale);
    sessions = std::make_unique<sim::SimulatedSessions>(config);
    const sim::SimulatedSession a = sessions->session("A");
    trajectory =
        std::make_unique<sim::VehicleTrajectory>(*a.world, a.plan.waypoints, config.motion, a.seed);
    sim::ImuConfig noise_free = config.imu;
    noise_free.accel_noise_density = noise_free.gyro_noise_density = 0.0;
    noise_free.accel_bias_random_walk = noise_free.gyro_bias_random_walk = 0.0;
    noise_free.initial_accel_bias_sigma_mps2 = noise_free.initial_gyro_bias_sigma_rps = 0.0;
    sim::ImuSimulator simulator(*trajectory, noise_free, a.seed, 0);
    while (simulator.next_time_s() <= trajectory->duration_s()) {
      ImuSample s = simulator.next();
      s.accel_mps2 += accel_bias;
      s.gyro_rps += gyro_bias;
      imu.push_back(s);
    }
    gravity_mps2 = noise_free.gravity_mps2;
  }
};

}  // namespace liloc::test
