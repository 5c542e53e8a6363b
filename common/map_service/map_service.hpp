#pragma once
// What the map server does, without the wire: answers submap requests from many robots
// (by position through Tree_m, or by id), chunked into parts of whole keyframes that fit
// a message, and grows the central session from incremental-localization updates
// (assembled from their chunks, validated, cut into new submaps by Eq. 2). The process
// converts messages to and from these types and saves the map.

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "descriptor/polar_descriptor.hpp"
#include "map/map_types.hpp"
#include "map/submap_clouds.hpp"
#include "map/submap_database.hpp"
#include "pointcloud/point_cloud.hpp"

namespace liloc {

struct MapServiceConfig {
  int max_submaps_per_reply = 4;
  // Keyframe clouds per reply message, in points (7 bytes each on the wire): a submap
  // beyond this is sent in several chunks of whole keyframes.
  int max_chunk_points = 150000;
  // Keyframe index replies (descriptors) per message, in bytes of descriptors.
  int max_descriptor_chunk_bytes = 400000;
  // Replies send each map voxel of this size once (map/submap_clouds.hpp; 0: the full
  // keyframe clouds, which overlap ~3x). The deduplicated clouds of a submap are computed
  // once and kept in the SubmapCloudStore given to the service, if any.
  double reply_voxel_m = 0.3;
  int reply_cache_submaps = 64;  // submaps' reply clouds kept in memory (~0.45 MB each)
  // Updates are accepted from these robots only; others are refused and counted (an empty
  // list refuses every update: a map grows only from robots the operator named).
  std::vector<std::string> allowed_robots;
  int max_update_keyframes = 1000;
  int64_t max_update_points = 20000000;  // in one update
  // Updates still missing chunks: at most this many and this many points in all (beyond,
  // new ones are refused until these complete or expire), each for update_timeout_s.
  int max_pending_updates = 8;
  int64_t max_pending_points = 5000000;
  double update_timeout_s = 30.0;
  // Merged updates remembered, so that a repeated part is ignored; the oldest are
  // forgotten beyond this.
  int max_finished_updates = 10000;

  template <class V>
  void visit_fields(V& v) {
    v("max_submaps_per_reply", max_submaps_per_reply);
    v("max_chunk_points", max_chunk_points);
    v("max_descriptor_chunk_bytes", max_descriptor_chunk_bytes);
    v("reply_voxel_m", reply_voxel_m);
    v("reply_cache_submaps", reply_cache_submaps);
    v("allowed_robots", allowed_robots);
    v("max_update_keyframes", max_update_keyframes);
    v("max_update_points", max_update_points);
    v("max_pending_updates", max_pending_updates);
    v("max_pending_points", max_pending_points);
    v("update_timeout_s", update_timeout_s);
    v("max_finished_updates", max_finished_updates);
  }
  void validate() const;
};

struct SubmapQuery {
  std::string robot_id;
  int64_t request_id = 0;
  bool by_id = false;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // map frame
  double radius_m = 0.0;                               // 0: the nearest submap only
  int max_submaps = 0;                                 // 0: the server's maximum
  std::vector<int64_t> submap_ids;
  bool include_clouds = true;
  std::string reply_url;  // empty: the request's bus (see submap_request_t)
};

// One message of a reply.
struct SubmapReplyPart {
  std::string robot_id;
  int64_t request_id = 0;
  int reply_index = 0;
  int reply_count = 0;
  int64_t map_version = 0;
  std::optional<Submap> submap;  // none: the request matched nothing
  int chunk_index = 0;
  int num_chunks = 0;
  std::vector<MapKeyframe> keyframes;  // this chunk's
  std::optional<SubmapClouds> clouds;  // of these keyframes; none without clouds
};

struct UpdateKeyframe {
  int64_t sender_keyframe_id = 0;
  int64_t utime_us = 0;
  Eigen::Isometry3d T_map_body = Eigen::Isometry3d::Identity();
  double fitness_m = 0.0;
  PointCloud cloud_body;
};

// One message of an update.
struct MapUpdatePart {
  std::string robot_id;
  std::string session_id;
  int64_t update_id = 0;
  int chunk_index = 0;
  int num_chunks = 0;
  int64_t base_map_version = 0;
  std::vector<UpdateKeyframe> keyframes;
};

// One keyframe of the map's index: what pose initialization searches before it asks for
// any cloud.
struct IndexedKeyframe {
  int64_t id = 0;
  int64_t submap_id = -1;
  Eigen::Isometry3d T_map_body = Eigen::Isometry3d::Identity();
  std::shared_ptr<const std::vector<uint8_t>> descriptor;  // encoded (Eq. 3)
};

// One message of a reply to a keyframe index request.
struct KeyframeIndexPart {
  std::string robot_id;
  int64_t request_id = 0;
  int64_t map_version = 0;
  int chunk_index = 0;
  int num_chunks = 0;
  std::vector<IndexedKeyframe> keyframes;
};

// The encoded descriptor of each keyframe of a map, by id (storage's .desc files).
using KeyframeDescriptors = std::map<int64_t, std::vector<uint8_t>>;

struct UpdateOutcome {
  enum class Status { kPending, kMerged, kRejected };
  Status status = Status::kPending;
  std::string reason;                      // why it was rejected
  std::vector<MapKeyframe> new_keyframes;  // merged, with their map ids
  std::vector<Submap> new_submaps;
};

struct MapServiceCounters {
  int64_t requests = 0;
  int64_t empty_replies = 0;
  int64_t updates_merged = 0;
  int64_t updates_rejected = 0;       // malformed, or the map's rules refuse it
  int64_t updates_refused_robot = 0;  // from a robot not in allowed_robots
  int64_t updates_refused_busy = 0;   // the pending bounds were reached
  int64_t updates_repeated = 0;       // a part of an update merged before: ignored
  int64_t updates_expired = 0;
  int64_t keyframes_merged = 0;
};

class MapService {
 public:
  // `descriptors`: those of the map's keyframes; merged keyframes get theirs computed with
  // `descriptor` (the map's). `submaps`: the rule (Eq. 2) that cut the map, which cuts
  // merged updates too. `store` (may be null; must outlive the service) keeps the
  // deduplicated reply clouds of submaps between requests and runs; its voxel size must be
  // config.reply_voxel_m.
  MapService(MapData map, KeyframeCloudSource clouds, const KeyframeDescriptors& descriptors,
             const MapServiceConfig& config, const SubmapConfig& submaps,
             const PolarDescriptorConfig& descriptor, const SubmapCloudStore* store = nullptr);
  MapService(const MapService&) = delete;
  MapService& operator=(const MapService&) = delete;

  std::vector<SubmapReplyPart> answer(const SubmapQuery& query);

  // The map's keyframe index (poses, submaps, descriptors) for `robot_id`, in chunks of at
  // most max_descriptor_chunk_bytes of descriptors.
  std::vector<KeyframeIndexPart> keyframe_index(const std::string& robot_id,
                                                int64_t request_id) const;

  // answer() in three steps, for a server that answers from several threads under one
  // lock: plan() with the lock held (cheap: ids, keyframes, cached clouds), complete()
  // without it (reads the submaps' clouds from the store, or else loads the keyframes'
  // through the cloud source, which must then be thread-safe, deduplicates and stores
  // them), remember() with the lock again (keeps those clouds for the next request).
  struct ReplyPlan {
    struct Item {
      Submap submap;
      std::vector<MapKeyframe> keyframes;          // the submap's, in order
      std::shared_ptr<const SubmapClouds> clouds;  // what the reply sends
      KeyframeClouds sources;                      // merged clouds, else null
      bool computed = false;
    };
    SubmapQuery query;
    int64_t map_version = 0;
    int64_t generation = 0;  // of the service's map when planned
    std::vector<Item> items;
  };
  ReplyPlan plan(const SubmapQuery& query);
  std::vector<SubmapReplyPart> complete(ReplyPlan& plan) const;
  void remember(const ReplyPlan& plan);

  // Buffers a part of an update; once all parts of it arrived and the map with it follows
  // the rules of map/map_validation.hpp (the rules a save checks), merges it into the
  // map. Malformed parts or updates are rejected with a reason. An update is known by
  // (robot, session, update id), and only merged ones are remembered: a rejected update
  // (a spoof, a robot's bad first try) never shadows a later one with the same ids, and a
  // robot that restarts its update ids in a new session is not mistaken for a repeat.
  UpdateOutcome receive(MapUpdatePart part, int64_t now_us);
  // An update part the process could not even convert (a non-finite pose, offsets that
  // do not fit its cloud): the whole update is rejected and counted, like one that fails
  // validation (nothing happens if it was merged before).
  UpdateOutcome reject(const std::string& robot_id, const std::string& session_id,
                       int64_t update_id, const std::string& reason);
  // Drops updates still incomplete after update_timeout_s (counted as expired).
  void expire(int64_t now_us);

  const MapData& map() const { return map_; }
  const MapServiceCounters& counters() const { return counters_; }
  // Reply clouds the store could not keep (they were sent all the same).
  int64_t store_errors() const { return store_errors_.load(); }
  // What was merged since the last call, clouds included: the process saves it, then
  // calls saved() with the version on disk, so that those keyframes' clouds are served from
  // storage from then on and replies name the saved version.
  MapDelta take_unsaved();
  void saved(int64_t version, const std::vector<int64_t>& keyframe_ids);
  // Merged updates still remembered (at most max_finished_updates), and updates waiting
  // for chunks (at most max_pending_updates).
  size_t finished_updates() const { return finished_.size(); }
  size_t pending_updates() const { return pending_.size(); }

 private:
  using UpdateKey = std::tuple<std::string, std::string, int64_t>;  // robot, session, update
  struct PendingUpdate {
    int num_chunks = 0;
    int64_t first_seen_us = 0;
    int64_t points = 0;
    std::map<int, std::vector<UpdateKeyframe>> chunks;
  };
  std::optional<std::string> validate(const MapUpdatePart& part) const;
  UpdateOutcome merge(const std::string& robot_id, const std::string& session_id,
                      PendingUpdate& update);
  UpdateOutcome refuse(int64_t& counter, const std::string& reason);
  // The update merged: repeats of it are ignored from now on.
  void remember_merged(const UpdateKey& key);
  // The clouds a reply sends for a submap: stored, or else computed and stored.
  std::shared_ptr<const SubmapClouds> reply_clouds(const ReplyPlan::Item& item) const;

  MapData map_;
  KeyframeCloudSource cloud_source_;
  MapServiceConfig config_;
  SubmapConfig submaps_;
  PolarDescriptorConfig descriptor_;
  std::map<int64_t, std::shared_ptr<const std::vector<uint8_t>>> descriptors_;  // by keyframe
  const SubmapCloudStore* store_;
  mutable std::atomic<int64_t> store_errors_{0};
  SubmapDatabase database_;
  MapServiceCounters counters_;
  std::map<UpdateKey, PendingUpdate> pending_;
  std::set<UpdateKey> finished_;          // merged: repeats ignored
  std::deque<UpdateKey> finished_order_;  // oldest first, to forget beyond the bound
  std::map<int64_t, std::shared_ptr<const PointCloud>> merged_clouds_;  // served until saved
  MapDelta unsaved_;  // merged since the last take_unsaved()
  std::map<int64_t, std::shared_ptr<const SubmapClouds>> reply_clouds_;
  std::deque<int64_t> reply_clouds_order_;  // least recently used first
  int64_t generation_ = 0;                  // +1 on every change of the map
};

}  // namespace liloc
