#include "odometry/motion_profile.hpp"

#include <algorithm>

#include "math/se3.hpp"
#include "math/so3.hpp"

namespace liloc {

Eigen::Isometry3d MotionProfile::pose_at(int64_t t_us) const {
  auto it = std::upper_bound(samples_.begin(), samples_.end(), t_us,
                             [](int64_t t, const MotionSample& s) { return t < s.utime_us; });
  const MotionSample& s = it == samples_.begin() ? *it : *(it - 1);
  const double dt = (t_us - s.utime_us) * 1e-6;
  return se3::make(s.R * so3::exp(s.omega_body * dt),
                   s.p + s.v * dt + 0.5 * s.accel_local * dt * dt);
}

}  // namespace liloc
