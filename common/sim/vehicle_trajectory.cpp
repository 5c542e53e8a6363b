#include "sim/vehicle_trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "math/so3.hpp"
#include "sim/random.hpp"

namespace liloc::sim {
namespace {

constexpr double kPathStepM = 0.25;

struct PathSample {
  Eigen::Vector2d position;
  double heading_rad;  // unwrapped
  double curvature;    // 1/m, positive to the left
};

Eigen::Vector2d right_of(const Eigen::Vector2d& d) { return Eigen::Vector2d(d.y(), -d.x()); }
Eigen::Vector2d left_of(const Eigen::Vector2d& d) { return Eigen::Vector2d(-d.y(), d.x()); }

// Appends samples every kPathStepM along a straight piece (excluding its start).
void add_line(std::vector<PathSample>& out, const Eigen::Vector2d& from,
              const Eigen::Vector2d& to) {
  const double length = (to - from).norm();
  if (length < 1e-9) {
    return;
  }
  const Eigen::Vector2d d = (to - from) / length;
  const double heading = std::atan2(d.y(), d.x());
  const int n = std::max(1, static_cast<int>(std::ceil(length / kPathStepM)));
  for (int i = 1; i <= n; ++i) {
    out.push_back({from + d * (length * i / n), heading, 0.0});
  }
}

// Appends samples along a circular arc around `center` from angle a0 sweeping `sweep`.
void add_arc(std::vector<PathSample>& out, const Eigen::Vector2d& center, double radius, double a0,
             double sweep) {
  const int n = std::max(1, static_cast<int>(std::ceil(std::abs(sweep) * radius / kPathStepM)));
  const double sign = sweep > 0 ? 1.0 : -1.0;
  for (int i = 1; i <= n; ++i) {
    const double a = a0 + sweep * i / n;
    out.push_back({center + radius * Eigen::Vector2d(std::cos(a), std::sin(a)), a + sign * M_PI / 2,
                   sign / radius});
  }
}

// The lane path through the waypoints: offset lines joined by fillets (or a U-turn).
std::vector<PathSample> build_path(std::vector<Eigen::Vector2d> waypoints, double lane_offset,
                                   double corner_radius) {
  waypoints.erase(std::unique(waypoints.begin(), waypoints.end(),
                              [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
                                return (a - b).norm() < 1e-6;
                              }),
                  waypoints.end());
  if (waypoints.size() < 2) {
    throw std::invalid_argument("a route needs at least two distinct waypoints");
  }
  const size_t m = waypoints.size() - 1;  // segments
  std::vector<Eigen::Vector2d> dir(m);
  std::vector<double> seg_len(m);
  for (size_t i = 0; i < m; ++i) {
    seg_len[i] = (waypoints[i + 1] - waypoints[i]).norm();
    dir[i] = (waypoints[i + 1] - waypoints[i]) / seg_len[i];
  }
  std::vector<PathSample> out;
  Eigen::Vector2d cursor = waypoints[0] + lane_offset * right_of(dir[0]);
  out.push_back({cursor, std::atan2(dir[0].y(), dir[0].x()), 0.0});
  for (size_t i = 1; i < m; ++i) {
    const Eigen::Vector2d& d0 = dir[i - 1];
    const Eigen::Vector2d& d1 = dir[i];
    const double turn = std::atan2(d0.x() * d1.y() - d0.y() * d1.x(), d0.dot(d1));
    const Eigen::Vector2d end_prev = waypoints[i] + lane_offset * right_of(d0);
    const Eigen::Vector2d start_next = waypoints[i] + lane_offset * right_of(d1);
    if (std::abs(turn) < 1e-3) {
      add_line(out, cursor, end_prev);
      cursor = end_prev;
    } else if (std::abs(turn) > 3.0) {
      // U-turn to the left around the waypoint, from the right lane to the other side.
      const double radius = std::max(lane_offset, 2.5);
      const Eigen::Vector2d center = waypoints[i] + (lane_offset - radius) * right_of(d0);
      const Eigen::Vector2d entry = center + radius * right_of(d0);
      add_line(out, cursor, entry);
      const Eigen::Vector2d r0 = entry - center;
      add_arc(out, center, radius, std::atan2(r0.y(), r0.x()), M_PI);
      cursor = out.back().position;
    } else {
      // Corner: the offset lines meet at X; a fillet of radius r replaces the corner.
      const Eigen::Vector2d x =
          end_prev + d0 * ((start_next - end_prev).dot(left_of(d1)) / d0.dot(left_of(d1)));
      const double max_tangent = 0.45 * std::min(seg_len[i - 1], seg_len[i]);
      const double radius = std::min(corner_radius, max_tangent / std::tan(std::abs(turn) / 2));
      const double tangent = radius * std::tan(std::abs(turn) / 2);
      const Eigen::Vector2d p1 = x - tangent * d0;
      const Eigen::Vector2d normal = turn > 0 ? left_of(d0) : right_of(d0);
      const Eigen::Vector2d center = p1 + radius * normal;
      add_line(out, cursor, p1);
      const Eigen::Vector2d r0 = p1 - center;
      add_arc(out, center, radius, std::atan2(r0.y(), r0.x()), turn);
      cursor = out.back().position;
    }
  }
  add_line(out, cursor, waypoints[m] + lane_offset * right_of(dir[m - 1]));
  // Unwrap headings so that yaw is continuous.
  for (size_t i = 1; i < out.size(); ++i) {
    double h = out[i].heading_rad;
    while (h - out[i - 1].heading_rad > M_PI) h -= 2 * M_PI;
    while (h - out[i - 1].heading_rad < -M_PI) h += 2 * M_PI;
    out[i].heading_rad = h;
  }
  return out;
}

}  // namespace

void MotionConfig::validate() const {
  if (cruise_speed_mps <= 0 || max_speed_mps < cruise_speed_mps) {
    throw std::invalid_argument("need 0 < cruise_speed_mps <= max_speed_mps");
  }
  if (max_lateral_accel_mps2 <= 0 || max_longitudinal_accel_mps2 <= 0 || corner_radius_m <= 0 ||
      knot_spacing_s <= 0) {
    throw std::invalid_argument(
        "accelerations, corner_radius_m and knot_spacing_s must be positive");
  }
}

VehicleTrajectory::VehicleTrajectory(const World& world,
                                     const std::vector<Eigen::Vector2d>& waypoints,
                                     const MotionConfig& config, uint64_t seed)
    : knot_spacing_s_(config.knot_spacing_s) {
  config.validate();
  const std::vector<PathSample> path =
      build_path(waypoints, world.roads().lane_offset_m(), config.corner_radius_m);
  const size_t n = path.size();
  std::vector<double> s(n, 0.0);
  for (size_t i = 1; i < n; ++i) {
    s[i] = s[i - 1] + (path[i].position - path[i - 1].position).norm();
  }
  length_m_ = s.back();

  // Speed limit along the path: a wandering cruise speed, capped by lateral acceleration
  // in curves; then forward and backward passes bound the longitudinal acceleration.
  Random rng(seed);
  double phases[3], wavelengths[3];
  for (int k = 0; k < 3; ++k) {
    phases[k] = rng.uniform(0, 2 * M_PI);
    wavelengths[k] = rng.uniform(80, 300);
  }
  std::vector<double> v(n);
  for (size_t i = 0; i < n; ++i) {
    double wander = 0.0;
    for (int k = 0; k < 3; ++k) {
      wander += std::sin(2 * M_PI * s[i] / wavelengths[k] + phases[k]) / 3.0;
    }
    double limit = std::min(config.max_speed_mps,
                            config.cruise_speed_mps * (1.0 + config.speed_variation * wander));
    if (std::abs(path[i].curvature) > 1e-9) {
      limit =
          std::min(limit, std::sqrt(config.max_lateral_accel_mps2 / std::abs(path[i].curvature)));
    }
    v[i] = std::max(limit, 0.5);
  }
  // Curvature jumps at fillet ends: look 5 m ahead and behind so braking starts in time.
  std::vector<double> v_smooth(v);
  const int window = static_cast<int>(5.0 / kPathStepM);
  for (size_t i = 0; i < n; ++i) {
    for (int k = -window; k <= window; ++k) {
      const long j = static_cast<long>(i) + k;
      if (j >= 0 && j < static_cast<long>(n)) {
        v_smooth[i] = std::min(v_smooth[i], v[j]);
      }
    }
  }
  v = v_smooth;
  const double a_max = config.max_longitudinal_accel_mps2;
  v[0] = 0.0;
  for (size_t i = 1; i < n; ++i) {
    v[i] = std::min(v[i], std::sqrt(v[i - 1] * v[i - 1] + 2 * a_max * (s[i] - s[i - 1])));
  }
  v[n - 1] = 0.0;
  for (size_t i = n - 1; i-- > 0;) {
    v[i] = std::min(v[i], std::sqrt(v[i + 1] * v[i + 1] + 2 * a_max * (s[i + 1] - s[i])));
  }
  std::vector<double> t(n, config.stationary_start_s);
  for (size_t i = 1; i < n; ++i) {
    t[i] = t[i - 1] + 2.0 * (s[i] - s[i - 1]) / std::max(v[i] + v[i - 1], 1e-6);
  }
  duration_s_ = t.back() + config.stationary_end_s;

  // Knot samples: position and heading from the path at s(t), height and attitude from
  // the terrain under the wheels.
  const int knots = static_cast<int>(std::ceil(duration_s_ / knot_spacing_s_)) + 1;
  control_.reserve(knots + 2);
  size_t j = 0;
  for (int k = 0; k < knots; ++k) {
    const double tau = k * knot_spacing_s_;
    while (j + 1 < n - 1 && t[j + 1] < tau) {
      ++j;
    }
    double alpha = 0.0;
    if (tau >= t[n - 1]) {
      j = n - 2;
      alpha = 1.0;
    } else if (tau > t[j]) {
      alpha = (tau - t[j]) / (t[j + 1] - t[j]);
    }
    const Eigen::Vector2d xy = (1 - alpha) * path[j].position + alpha * path[j + 1].position;
    const double yaw = (1 - alpha) * path[j].heading_rad + alpha * path[j + 1].heading_rad;
    const Eigen::Vector2d fwd(std::cos(yaw), std::sin(yaw));
    const Eigen::Vector2d left = left_of(fwd);
    const auto h = [&](const Eigen::Vector2d& p) { return world.ground_height(p.x(), p.y()); };
    const double hf = 0.5 * (h(xy + 0.5 * config.wheelbase_m * fwd + 0.5 * config.track_m * left) +
                             h(xy + 0.5 * config.wheelbase_m * fwd - 0.5 * config.track_m * left));
    const double hr = 0.5 * (h(xy - 0.5 * config.wheelbase_m * fwd + 0.5 * config.track_m * left) +
                             h(xy - 0.5 * config.wheelbase_m * fwd - 0.5 * config.track_m * left));
    const double hl = 0.5 * (h(xy + 0.5 * config.wheelbase_m * fwd + 0.5 * config.track_m * left) +
                             h(xy - 0.5 * config.wheelbase_m * fwd + 0.5 * config.track_m * left));
    const double hrt = 0.5 * (h(xy + 0.5 * config.wheelbase_m * fwd - 0.5 * config.track_m * left) +
                              h(xy - 0.5 * config.wheelbase_m * fwd - 0.5 * config.track_m * left));
    Eigen::Matrix<double, 6, 1> c;
    c << xy.x(), xy.y(), 0.5 * (hf + hr) + config.ride_height_m, yaw,
        std::atan2(hr - hf, config.wheelbase_m),  // nose up = negative pitch about y
        std::atan2(hl - hrt, config.track_m);
    control_.push_back(c);
  }
  // Pad so that the spline is defined (and flat) at both ends.
  control_.insert(control_.begin(), control_.front());
  control_.push_back(control_.back());
  control_.push_back(control_.back());
}

VehicleState VehicleTrajectory::state(double t) const {
  const double max_t = (static_cast<double>(control_.size()) - 3.0) * knot_spacing_s_ - 1e-9;
  t = std::clamp(t, 0.0, std::min(duration_s_, max_t));
  const double x = t / knot_spacing_s_;
  const int i = static_cast<int>(std::floor(x));
  const double u = x - i;
  // Uniform cubic B-spline basis and its derivatives in u.
  const double b[4] = {(1 - u) * (1 - u) * (1 - u) / 6, (3 * u * u * u - 6 * u * u + 4) / 6,
                       (-3 * u * u * u + 3 * u * u + 3 * u + 1) / 6, u * u * u / 6};
  const double db[4] = {-(1 - u) * (1 - u) / 2, (3 * u * u - 4 * u) / 2,
                        (-3 * u * u + 2 * u + 1) / 2, u * u / 2};
  const double ddb[4] = {1 - u, 3 * u - 2, -3 * u + 1, u};
  Eigen::Matrix<double, 6, 1> p = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::Matrix<double, 6, 1> dp = p;
  Eigen::Matrix<double, 6, 1> ddp = p;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Matrix<double, 6, 1>& c = control_[i + k];
    p += b[k] * c;
    dp += db[k] * c;
    ddp += ddb[k] * c;
  }
  dp /= knot_spacing_s_;
  ddp /= knot_spacing_s_ * knot_spacing_s_;

  VehicleState st;
  const double yaw = p[3], pitch = p[4], roll = p[5];
  st.T_world_body.linear() = so3::from_rpy(Eigen::Vector3d(roll, pitch, yaw));
  st.T_world_body.translation() = p.head<3>();
  st.velocity_world = dp.head<3>();
  st.acceleration_world = ddp.head<3>();
  // Body rates from ZYX Euler rates.
  const double dyaw = dp[3], dpitch = dp[4], droll = dp[5];
  st.angular_velocity_body =
      Eigen::Vector3d(droll - dyaw * std::sin(pitch),
                      dpitch * std::cos(roll) + dyaw * std::cos(pitch) * std::sin(roll),
                      -dpitch * std::sin(roll) + dyaw * std::cos(pitch) * std::cos(roll));
  return st;
}

}  // namespace liloc::sim
