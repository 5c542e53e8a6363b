#include "bridge/pcl_conversions.hpp"

#include <cmath>

namespace liloc::bridge {

pcl::PointCloud<pcl::PointXYZI> to_pcl(const PointCloud& cloud) {
  pcl::PointCloud<pcl::PointXYZI> out;
  out.resize(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    pcl::PointXYZI& p = out[i];
    p.x = cloud.points[i].x();
    p.y = cloud.points[i].y();
    p.z = cloud.points[i].z();
    p.intensity = cloud.intensities[i];
  }
  out.width = static_cast<uint32_t>(cloud.size());
  out.height = 1;
  out.is_dense = true;
  return out;
}

PointCloud from_pcl(const pcl::PointCloud<pcl::PointXYZI>& cloud) {
  PointCloud out;
  out.reserve(cloud.size());
  for (const pcl::PointXYZI& p : cloud) {
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) {
      out.push_back(Eigen::Vector3f(p.x, p.y, p.z),
                    std::isfinite(p.intensity) ? p.intensity : 0.0f);
    }
  }
  return out;
}

}  // namespace liloc::bridge
