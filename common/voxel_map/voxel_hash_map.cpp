#include "voxel_map/voxel_hash_map.hpp"

#include <cmath>
#include <span>
#include <stdexcept>

namespace liloc {

void VoxelMapConfig::validate() const {
  if (voxel_m <= 0.0 || min_point_spacing_m < 0.0 || keep_radius_m <= 0.0) {
    throw std::invalid_argument("voxel_m and keep_radius_m must be positive");
  }
  if (max_points_per_voxel < 1 || max_points_per_voxel > VoxelHashMap::kMaxPointsPerVoxel) {
    throw std::invalid_argument("max_points_per_voxel must be within 1 .. " +
                                std::to_string(VoxelHashMap::kMaxPointsPerVoxel));
  }
}

VoxelHashMap::VoxelHashMap(const VoxelMapConfig& config)
    : config_(config),
      inv_voxel_(static_cast<float>(1.0 / config.voxel_m)),
      min_spacing_sq_(static_cast<float>(config.min_point_spacing_m * config.min_point_spacing_m)),
      index_(1 << 15) {
  config_.validate();
}

Eigen::Vector3i VoxelHashMap::index_of(const Eigen::Vector3f& p) const {
  return Eigen::Vector3i(static_cast<int>(std::floor(p.x() * inv_voxel_)),
                         static_cast<int>(std::floor(p.y() * inv_voxel_)),
                         static_cast<int>(std::floor(p.z() * inv_voxel_)));
}

namespace {

ViewDirection quantized(const Eigen::Vector3f& unit) {
  return (127.0f * unit).array().round().cast<int8_t>();
}

}  // namespace

void VoxelHashMap::insert(const Eigen::Vector3f* points, size_t count) {
  for (size_t k = 0; k < count; ++k) {
    insert_one(points[k], ViewDirection::Zero());
  }
}

void VoxelHashMap::insert(const std::vector<Eigen::Vector3f>& points,
                          const Eigen::Vector3f& sensor_origin) {
  for (const Eigen::Vector3f& p : points) {
    insert_one(p, quantized((sensor_origin - p).normalized()));
  }
}

void VoxelHashMap::insert(const VoxelHashMap& other, const Eigen::Isometry3f& T_this_other) {
  for (const Voxel& v : other.voxels_) {
    for (int i = 0; i < v.count; ++i) {
      const Eigen::Vector3f view = T_this_other.linear() * (v.views[i].cast<float>() / 127.0f);
      insert_one(T_this_other * v.points[i], quantized(view.normalized()));
    }
  }
}

void VoxelHashMap::insert_one(const Eigen::Vector3f& p, const ViewDirection& view) {
  const auto [index, inserted] = index_.insert(voxel_key(index_of(p)));
  if (inserted) {
    voxels_.emplace_back();
  }
  Voxel& v = voxels_[index];
  if (v.count >= config_.max_points_per_voxel) {
    return;
  }
  for (int i = 0; i < v.count; ++i) {
    if ((v.points[i] - p).squaredNorm() < min_spacing_sq_) {
      return;
    }
  }
  v.points[v.count] = p;
  v.views[v.count] = view;
  ++v.count;
  ++num_points_;
}

void VoxelHashMap::remove_far(const Eigen::Vector3d& center) {
  const double r2 = config_.keep_radius_m * config_.keep_radius_m;
  std::vector<uint64_t> kept_keys;
  kept_keys.reserve(voxels_.size());
  size_t kept = 0;
  for (size_t i = 0; i < voxels_.size(); ++i) {
    if ((voxels_[i].points[0].cast<double>() - center).squaredNorm() > r2) {
      num_points_ -= voxels_[i].count;
      continue;
    }
    voxels_[kept++] = voxels_[i];
    kept_keys.push_back(index_.keys()[i]);
  }
  if (kept != voxels_.size()) {
    voxels_.resize(kept);
    index_.assign(std::move(kept_keys));
  }
}

std::vector<Eigen::Vector3f> VoxelHashMap::points() const {
  std::vector<Eigen::Vector3f> out;
  out.reserve(num_points_);
  for (const Voxel& v : voxels_) {
    out.insert(out.end(), v.points.begin(), v.points.begin() + v.count);
  }
  return out;
}

}  // namespace liloc
