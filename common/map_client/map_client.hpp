#pragma once
// A robot-side client of the map server, for the nodes that localize against the central
// session (the initializer, the optimizer): the map's keyframe index (MAP.INFO, and the
// index on the robot's reply route: <robot>.DESCRIPTORS) and submaps' points in the map
// frame (<robot>.SUBMAP), fetched when asked for and cached. Requests not answered within
// request_period_s go again, so that its owner keeps working when the server starts after
// it or restarts; when the map grows (a new MAP.INFO version) the index is asked for again.

#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "descriptor/polar_descriptor.hpp"
#include "initializer/map_index.hpp"
#include "initializer/pose_initializer.hpp"
#include "map_service/map_service.hpp"
#include "transport/channels.hpp"
#include "transport/transport.hpp"

namespace liloc {

struct MapClientConfig {
  double request_period_s = 2.0;  // requests not answered by then are sent again
  int max_cached_submaps = 64;    // submaps' points kept (least recently received out)
  void validate() const;
};

class MapClient {
 public:
  struct Counters {
    int64_t index_requests = 0;
    int64_t submap_requests = 0;
    int64_t rejected_messages = 0;  // that did not convert
  };

  // `on_ready` runs when the index is (re)built and when the last submap asked for arrives.
  MapClient(transport::Transport& bus, const std::string& robot_id,
            const transport::ChannelConfig& channels, const PolarDescriptorConfig& descriptor,
            const MapClientConfig& config, std::function<void()> on_ready);

  // The map's keyframe index; null until the server has sent it.
  const MapIndex* index() const { return index_.get(); }
  // Registration targets from the cached submaps.
  const SubmapTargets& targets() const { return targets_; }
  // Asks the server for these submaps (those already asked for within the period: not again).
  void request_submaps(const std::vector<int64_t>& ids, int64_t now_us);
  // Requests due again; the index when it is missing or stale.
  void tick(int64_t now_us);
  // The reply route's transport, if not the bus (for Node::own_transports()).
  std::vector<transport::Transport*> own_transports();

  const Counters& counters() const { return counters_; }
  size_t cached_submaps() const { return submaps_.size(); }
  // What a node waiting for the index should say.
  std::string waiting_for_index() const;
  // The latest problem with the map server's replies, empty if none.
  const std::string& error() const { return error_; }

 private:
  void on_map_info(MapData info);
  void on_index_part(KeyframeIndexPart part);
  void build_index();  // once every chunk of the latest reply and MAP.INFO are here
  void on_submap(SubmapReplyPart part);
  void request_index(int64_t now_us);
  std::shared_ptr<const std::vector<Eigen::Vector3f>> submap_points(int64_t id) const;

  transport::Transport& bus_;
  std::unique_ptr<transport::Transport> replies_;  // the reply route, if not the bus
  std::string robot_id_;
  transport::ChannelConfig channels_;
  PolarDescriptorConfig descriptor_;
  MapClientConfig config_;
  std::function<void()> on_ready_;
  SubmapTargets targets_;

  std::optional<MapData> map_info_;  // MAP.INFO's version and submaps
  std::unique_ptr<MapIndex> index_;
  int64_t index_request_id_ = 0;
  int64_t index_requested_us_ = 0;
  std::map<int, KeyframeIndexPart> index_chunks_;  // of the latest request
  int64_t submap_request_id_ = 0;
  std::map<int64_t, int64_t> submaps_requested_us_;  // by submap id, until they arrive
  std::map<int64_t, std::vector<SubmapReplyPart>> submap_chunks_;
  std::map<int64_t, std::shared_ptr<const std::vector<Eigen::Vector3f>>> submaps_;
  std::deque<int64_t> submap_order_;  // oldest first
  Counters counters_;
  std::string error_;
};

}  // namespace liloc
