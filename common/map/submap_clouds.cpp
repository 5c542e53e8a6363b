#include "map/submap_clouds.hpp"

#include "pointcloud/voxel_grid.hpp"
#include "pointcloud/voxel_index_table.hpp"

namespace liloc {

SubmapClouds SubmapClouds::keyframe_range(size_t first, size_t end) const {
  SubmapClouds out;
  out.cloud = slice(cloud, offsets[first], offsets[end]);
  out.offsets.clear();
  for (size_t k = first; k <= end; ++k) {
    out.offsets.push_back(offsets[k] - offsets[first]);
  }
  return out;
}

SubmapClouds deduplicate_submap_clouds(const std::vector<MapKeyframe>& keyframes,
                                       const KeyframeClouds& clouds, double voxel_m) {
  const float voxel = static_cast<float>(voxel_m);
  VoxelIndexTable seen(1 << 16);
  PointCloud kept;
  std::vector<uint32_t> offsets{0};
  for (size_t k = 0; k < keyframes.size(); ++k) {
    const PointCloud& full = *clouds[k];
    const Eigen::Affine3f T_map_body(keyframes[k].T_map_body.cast<float>());
    for (size_t i = 0; i < full.size(); ++i) {
      if (full.points[i].allFinite() &&
          (voxel_m <= 0.0 ||
           seen.insert(voxel_key(voxel_index(T_map_body * full.points[i], voxel))).second)) {
        kept.push_back(full.points[i], full.intensities[i]);
      }
    }
    offsets.push_back(static_cast<uint32_t>(kept.size()));
  }
  return {quantize(kept), std::move(offsets)};
}

int fill_submap_cloud_store(const MapData& map, const KeyframeCloudSource& clouds,
                            const SubmapCloudStore& store, const std::function<bool()>& stop) {
  if (store.voxel_m() <= 0.0) {
    return 0;
  }
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
    KeyframeClouds full;
    for (const int64_t id : submap.keyframe_ids) {
      full.push_back(clouds(id));
    }
    store.save(submap, keyframes, deduplicate_submap_clouds(keyframes, full, store.voxel_m()));
    ++computed;
  }
  return computed;
}

}  // namespace liloc
