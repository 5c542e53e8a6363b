#pragma once
// What the map server sends for a submap: the clouds of its keyframes, each in its body
// frame. A submap's keyframes overlap heavily (1 m apart, each seeing ~100 m), so with a
// voxel size > 0 each map voxel is sent once, by the first keyframe of the submap that
// has a point in it. The result is quantized once, as it travels (CompactCloud). It is
// derived data: computed once per submap and kept in a SubmapCloudStore
// (storage/submap_cloud_files: files next to the map), so that a request copies bytes.

#include <functional>
#include <memory>
#include <optional>
#include <unordered_map>
#include <vector>

#include "map/map_types.hpp"
#include "pointcloud/compact_cloud.hpp"
#include "pointcloud/point_cloud.hpp"

namespace liloc {

// Full keyframe clouds, as the map stores them, each in its body frame.
using KeyframeClouds = std::vector<std::shared_ptr<const PointCloud>>;
using KeyframeCloudSource = std::function<std::shared_ptr<const PointCloud>(int64_t keyframe_id)>;

// The clouds a reply sends for consecutive keyframes (of a submap, or a chunk of one),
// in one CompactCloud: keyframe k owns points [offsets[k], offsets[k + 1]), in its own
// body frame.
struct SubmapClouds {
  CompactCloud cloud;
  std::vector<uint32_t> offsets{0};  // one more than keyframes

  size_t keyframes() const { return offsets.size() - 1; }
  size_t points_of(size_t k) const { return offsets[k + 1] - offsets[k]; }
  PointCloud keyframe_cloud(size_t k) const {
    return dequantize(cloud, offsets[k], offsets[k + 1]);
  }
  // Keyframes [first, end), their offsets starting at 0.
  SubmapClouds keyframe_range(size_t first, size_t end) const;
};

// The submap's clouds from its keyframes' (`clouds[k]` of `keyframes[k]`), non-finite
// points left out: all points with voxel_m = 0, else each voxel_m map voxel in the first
// keyframe that has it.
SubmapClouds deduplicate_submap_clouds(const std::vector<MapKeyframe>& keyframes,
                                       const KeyframeClouds& clouds, double voxel_m);

// The keyframes of each submap of `map`, in the order of map.submaps.
inline std::vector<std::vector<MapKeyframe>> keyframes_of_submaps(const MapData& map) {
  std::unordered_map<int64_t, const MapKeyframe*> by_id;
  for (const MapKeyframe& kf : map.keyframes) {
    by_id[kf.id] = &kf;
  }
  std::vector<std::vector<MapKeyframe>> out;
  out.reserve(map.submaps.size());
  for (const Submap& submap : map.submaps) {
    std::vector<MapKeyframe>& keyframes = out.emplace_back();
    for (const int64_t id : submap.keyframe_ids) {
      keyframes.push_back(*by_id.at(id));
    }
  }
  return out;
}

// Where deduplicated submap clouds are kept, keyed by what they derive from (the submap's
// keyframe ids and poses, and the voxel size), so that a changed submap never gets
// another's clouds. Implementations are thread-safe.
class SubmapCloudStore {
 public:
  virtual ~SubmapCloudStore() = default;
  virtual double voxel_m() const = 0;
  virtual bool contains(const Submap& submap, const std::vector<MapKeyframe>& keyframes) const = 0;
  // Nothing if the store has no (intact) clouds for the submap as it is now.
  virtual std::optional<SubmapClouds> load(const Submap& submap,
                                           const std::vector<MapKeyframe>& keyframes) const = 0;
  virtual void save(const Submap& submap, const std::vector<MapKeyframe>& keyframes,
                    const SubmapClouds& clouds) const = 0;
};

// Computes and saves the clouds of every submap of `map` that the store lacks, until
// `stop` (if given) returns true. Returns how many were computed: none for a store of
// voxel size 0, since replies then send the keyframe clouds as they are.
int fill_submap_cloud_store(const MapData& map, const KeyframeCloudSource& clouds,
                            const SubmapCloudStore& store,
                            const std::function<bool()>& stop = nullptr);

}  // namespace liloc
