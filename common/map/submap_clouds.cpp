#include "map/submap_clouds.hpp"

#include "pointcloud/voxel_grid.hpp"
#include "pointcloud/voxel_index_table.hpp"

namespace liloc {

SubmapClouds deduplicate_submap_clouds(const std::vector<MapKeyframe>& keyframes,
                                       const SubmapClouds& clouds, double voxel_m) {
  if (voxel_m <= 0.0) {
    return clouds;
  }
  SubmapClouds out;
  out.reserve(keyframes.size());
  const float voxel = static_cast<float>(voxel_m);
  VoxelIndexTable seen(1 << 16);
  for (size_t k = 0; k < keyframes.size(); ++k) {
    const PointCloud& full = *clouds[k];
    const Eigen::Affine3f T_map_body(keyframes[k].T_map_body.cast<float>());
    auto kept = std::make_shared<PointCloud>();
    for (size_t i = 0; i < full.size(); ++i) {
      if (seen.insert(voxel_key(voxel_index(T_map_body * full.points[i], voxel))).second) {
        kept->points.push_back(full.points[i]);
        kept->intensities.push_back(full.intensities[i]);
      }
    }
    out.push_back(std::move(kept));
  }
  return out;
}

int fill_submap_cloud_store(const MapData& map, const KeyframeCloudSource& clouds,
                            const SubmapCloudStore& store, const std::function<bool()>& stop) {
  const std::vector<std::vector<MapKeyframe>> keyframes_of = keyframes_of_submaps(map);
  int computed = 0;
  for (size_t s = 0; s < map.submaps.size(); ++s) {
    if (stop && stop()) {
      break;
    }
    const Submap& submap = map.submaps[s];
    const std::vector<MapKeyframe>& keyframes = keyframes_of[s];
    if (store.contains(submap, keyframes)) {
      continue;
    }
    SubmapClouds full;
    for (const int64_t id : submap.keyframe_ids) {
      full.push_back(clouds(id));
    }
    store.save(submap, keyframes, deduplicate_submap_clouds(keyframes, full, store.voxel_m()));
    ++computed;
  }
  return computed;
}

}  // namespace liloc
