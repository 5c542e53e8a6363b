#include "dataset/tum_trajectory.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "math/se3.hpp"

namespace liloc {

Trajectory read_tum(const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    throw std::runtime_error(path + ": cannot open TUM trajectory");
  }
  std::vector<StampedPose> poses;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') {
      continue;
    }
    const auto fail = [&](const std::string& what) {
      throw std::runtime_error(path + ":" + std::to_string(line_number) + ": " + what);
    };
    std::istringstream fields(line);
    std::vector<std::string> tokens;
    for (std::string token; fields >> token;) {
      tokens.push_back(token);
    }
    if (tokens.size() < 8) {
      fail("expected 8 numbers 'time tx ty tz qx qy qz qw'");
    }
    if (tokens.size() > 8) {
      fail("more than 8 fields");
    }
    double v[8];
    for (int i = 0; i < 8; ++i) {
      char* end = nullptr;
      v[i] = std::strtod(tokens[i].c_str(), &end);
      if (end == tokens[i].c_str() || *end != '\0') {
        fail("'" + tokens[i] + "' is not a number");
      }
      if (!std::isfinite(v[i])) {
        fail("non-finite value");
      }
    }
    const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    if (std::abs(q.norm() - 1.0) > 1e-3) {
      fail("quaternion norm " + std::to_string(q.norm()) + " is not 1");
    }
    poses.push_back({v[0], se3::make(q, Eigen::Vector3d(v[1], v[2], v[3]))});
  }
  try {
    return Trajectory(std::move(poses));
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
}

void write_tum(const std::string& path, const Trajectory& trajectory) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) {
    throw std::runtime_error(path + ": cannot write TUM trajectory");
  }
  std::fprintf(f, "# time_s tx ty tz qx qy qz qw\n");
  for (const StampedPose& p : trajectory.poses()) {
    const Eigen::Quaterniond q(p.T.linear());
    const Eigen::Vector3d& t = p.T.translation();
    std::fprintf(f, "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", p.time_s, t.x(), t.y(), t.z(),
                 q.x(), q.y(), q.z(), q.w());
  }
  if (std::fclose(f) != 0) {
    throw std::runtime_error(path + ": write failed");
  }
}

}  // namespace liloc
