#pragma once
// Conversions between core clouds and PCL. The only PCL include of the bridge; keep PCL
// out of other headers (its headers are slow to compile).

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "pointcloud/point_cloud.hpp"

namespace liloc::bridge {

pcl::PointCloud<pcl::PointXYZI> to_pcl(const PointCloud& cloud);
// Non-finite points (PCL's "invalid" NaN points of organized clouds) are dropped.
PointCloud from_pcl(const pcl::PointCloud<pcl::PointXYZI>& cloud);

}  // namespace liloc::bridge
