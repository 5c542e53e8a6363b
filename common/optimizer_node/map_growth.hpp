#pragma once
// The central session grows from a robot's ILM stretches (paper Section IV-D, Algorithm 1):
// keyframes optimized in ILM are kept with their clouds until their poses are final (they
// left the sliding window, marginalized), then go to the map server as a MAP.UPDATE, which
// cuts them into new submaps by Eq. 2, merges and saves them. No transport: the optimizer's
// node sends what take_updates() returns.

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "map_service/map_service.hpp"
#include "optimizer/egocentric_factor_graph.hpp"
#include "optimizer/localizer.hpp"

namespace liloc {

struct MapGrowthConfig {
  bool enabled = true;
  // An update once this many ILM keyframes are final, or when every kept one is (the
  // stretch ended and its last keyframes left the window).
  int update_keyframes = 10;
  // Points per MAP.UPDATE message (whole keyframes): 100 000 points are 1.6 MB on the wire.
  int max_chunk_points = 100000;

  template <class V>
  void visit_fields(V& v) {
    v("enabled", enabled);
    v("update_keyframes", update_keyframes);
    v("max_chunk_points", max_chunk_points);
  }
  void validate() const;
};

class MapGrowth {
 public:
  MapGrowth(const MapGrowthConfig& config, std::string robot_id);

  // A keyframe optimized in ILM, at its estimate so far.
  void add(const LocalizerKeyframe& keyframe, const Eigen::Isometry3d& T_map_body);
  // Keyframes that left the window (GraphEstimate::finalized): their final poses.
  void finalize(const std::vector<KeyframePose>& finalized);
  // The update due now, in its messages (none if nothing is due); `flush`: every kept
  // keyframe, final or not (the session ends). `session_id` names the robot's session.
  std::vector<MapUpdatePart> take_update(const std::string& session_id, int64_t base_map_version,
                                         bool flush);
  // Forgets what is kept (estimates no longer trusted: tracking was lost).
  size_t discard();

  size_t kept() const { return keyframes_.size(); }
  int64_t keyframes_sent() const { return keyframes_sent_; }
  int64_t updates_sent() const { return next_update_id_ - 1; }

 private:
  struct Kept {
    UpdateKeyframe keyframe;
    bool final = false;
  };
  MapGrowthConfig config_;
  std::string robot_id_;
  std::map<int64_t, Kept> keyframes_;  // by the robot's keyframe id
  int64_t next_update_id_ = 1;
  int64_t keyframes_sent_ = 0;
};

}  // namespace liloc
