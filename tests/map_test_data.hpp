#pragma once
// Map data for the tests of the map modules, the map server node and its process.

#include <map>
#include <string>
#include <vector>

#include "map/keyframe_descriptors.hpp"
#include "map/map_types.hpp"
#include "map/submap_database.hpp"
#include "storage/map_store.hpp"

namespace liloc::test {

// n keyframes of one session along x, spacing_m apart, ids from 0.
inline std::vector<MapKeyframe> straight_drive(int n, double spacing_m,
                                               const std::string& session) {
  std::vector<MapKeyframe> kfs;
  for (int i = 0; i < n; ++i) {
    MapKeyframe kf;
    kf.id = i;
    kf.session = session;
    kf.T_map_body.translation() = Eigen::Vector3d(spacing_m * i, 0, 0);
    kfs.push_back(kf);
  }
  return kfs;
}

// 45 keyframes one metre apart along x, each seeing a 10 m x 6 m patch of ground ahead of
// it (a point every 0.2 m): three submaps by Eq. 2 (20, 20 and 5 keyframes).
inline std::map<int64_t, PointCloud> write_map(const std::string& dir) {
  MapData map;
  map.map_id = "process-test";
  map.keyframes = straight_drive(45, 1.0, "A");
  std::map<int64_t, PointCloud> clouds;
  for (MapKeyframe& kf : map.keyframes) {
    kf.utime_us = 1000000LL * kf.id;
    PointCloud& cloud = clouds[kf.id];
    for (int x = 0; x < 50; ++x) {
      for (int y = -15; y < 15; ++y) {
        cloud.push_back(Eigen::Vector3f(0.2f * x, 0.2f * y, -1.0f), static_cast<float>(x));
      }
    }
  }
  map.submaps = join_submaps(map.keyframes, SubmapConfig{}, 0);
  storage::MapStore(dir).save(
      map, clouds, encode_keyframe_descriptors(map.keyframes, clouds, PolarDescriptorConfig{}));
  return clouds;
}

}  // namespace liloc::test
