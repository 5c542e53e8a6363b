#include "initializer/map_directory.hpp"

#include <map>
#include <mutex>

#include "pointcloud/voxel_grid.hpp"

namespace liloc {

MapIndex load_map_index(const storage::MapStore& store, const MapData& map,
                        const PolarDescriptorConfig& descriptor) {
  std::map<int64_t, std::vector<uint8_t>> descriptors;
  for (const MapKeyframe& kf : map.keyframes) {
    descriptors[kf.id] = store.load_descriptor(kf.id);
  }
  return MapIndex(map, descriptors, descriptor);
}

SubmapTargets::Source submap_points_from(const storage::MapStore& store, const MapData& map,
                                         double voxel_m) {
  struct Cache {
    std::mutex mutex;
    std::map<int64_t, std::shared_ptr<const std::vector<Eigen::Vector3f>>> submaps;
  };
  auto cache = std::make_shared<Cache>();
  return [&store, &map, voxel_m, cache](int64_t id) {
    std::lock_guard<std::mutex> lock(cache->mutex);
    std::shared_ptr<const std::vector<Eigen::Vector3f>>& points = cache->submaps[id];
    if (!points) {
      PointCloud all;
      for (const MapKeyframe& kf : map.keyframes) {
        if (kf.submap_id != id) {
          continue;
        }
        const Eigen::Isometry3f T = kf.T_map_body.cast<float>();
        const PointCloud cloud = store.load_cloud(kf.id);
        for (size_t i = 0; i < cloud.size(); ++i) {
          all.push_back(T * cloud.points[i], cloud.intensities[i]);
        }
      }
      points = std::make_shared<const std::vector<Eigen::Vector3f>>(
          voxel_downsample(all, static_cast<float>(voxel_m)).points);
    }
    return points;
  };
}

OpenedMap::OpenedMap(const std::string& directory, const PolarDescriptorConfig& descriptor,
                     double voxel_m)
    : store(directory),
      data(store.load()),
      index(load_map_index(store, data, descriptor)),
      points(submap_points_from(store, data, voxel_m)) {}

}  // namespace liloc
