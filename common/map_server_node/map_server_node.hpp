#pragma once
// The map server's logic (docs/map_server.md): serves the central session to every robot
// and grows it.
//   in:  MAP.REQUEST (submap_request_t), MAP.DESCRIPTOR_REQUEST (descriptor_request_t),
//        MAP.UPDATE (map_update_t)
//   out: <robot>.SUBMAP (submap_t), <robot>.DESCRIPTORS (keyframe_descriptors_t), MAP.INFO
//        (map_info_t), MAP.STATUS
// Position queries, keyframe index requests (the map's descriptors, for initialization)
// and updates are handled on the message thread; replies with clouds on
// worker threads (so that a burst of them never holds up the small ones); merged updates
// are saved as new map versions by a MapSaver on a thread of its own.

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>

#include "app/worker_pool.hpp"
#include "descriptor/polar_descriptor.hpp"
#include "map/submap_database.hpp"
#include "map_server_node/map_saver.hpp"
#include "map_service/map_service.hpp"
#include "node/node.hpp"
#include "storage/cloud_cache.hpp"
#include "storage/map_store.hpp"
#include "storage/submap_cloud_files.hpp"
#include "transport/channels.hpp"
#include "transport/transport.hpp"

namespace liloc {
namespace bridge {
struct DescriptorRequest;
struct ReceivedMapUpdate;
}  // namespace bridge

struct MapServerConfig {
  std::string map_directory = "data/map";
  double cache_mb = 512.0;     // keyframe clouds held in memory
  double info_period_s = 1.0;  // MAP.INFO and status
  int keep_versions = 5;       // saved versions kept on disk
  // Threads that answer requests with clouds. Two halve the wait of a burst (robots
  // entering submaps at once) on a 2-core machine: bench_mapserver's cloud-reply p99.
  int reply_threads = 2;
  std::string status_channel = "MAP.STATUS";
  MapServiceConfig service;

  template <class V>
  void visit_fields(V& v) {
    v("map_directory", map_directory);
    v("cache_mb", cache_mb);
    v("info_period_s", info_period_s);
    v("keep_versions", keep_versions);
    v("reply_threads", reply_threads);
    v("status_channel", status_channel);
    v("service", service);
  }
  void validate() const;
};

// The sections of the system config the map server node reads.
struct MapServerNodeConfig {
  transport::ChannelConfig channels;
  PolarDescriptorConfig descriptor;  // of the keyframes merged updates bring
  SubmapConfig submaps;              // Eq. 2 for merged updates: the rule the map was cut by
  MapServerConfig map_server;

  template <class V>
  void visit_fields(V& v) {
    v("channels", channels);
    v("descriptor", descriptor);
    v("submaps", submaps);
    v("map_server", map_server);
  }
};

class MapServerNode final : public node::Node {
 public:
  // `store` holds `map` (its current version) and must outlive the node. Starts computing
  // missing submap reply clouds in the background (or warms the cloud cache).
  MapServerNode(transport::Transport& bus, const MapServerNodeConfig& config,
                storage::MapStore& store, MapData map);
  ~MapServerNode() override;

  std::string name() const override { return "map_server"; }
  // Saves' outcomes, expiry of incomplete updates, MAP.INFO and MAP.STATUS.
  void tick(int64_t now_us) override;
  // Waits for the pending saves; false if merged keyframes could not be saved.
  bool finish() override;

  // The map as served (merged updates included).
  MapData map() const;

 private:
  struct CloudRequest {
    SubmapQuery query;
    int64_t request_utime = 0;
    int64_t received_us = 0;
  };

  static KeyframeDescriptors load_descriptors(const storage::MapStore& store, const MapData& map);
  // Converted at the door (bridge/).
  void on_descriptor_request(const bridge::DescriptorRequest& request);
  void on_update(bridge::ReceivedMapUpdate update);
  void take_save_results();
  // Answers one request: planned under the service lock; clouds gathered, encoded and
  // sent without it, so that other requests and updates go on meanwhile.
  void reply(const SubmapQuery& query, int64_t request_utime, int64_t received_us);
  // The bus a reply to `robot_id` goes to (node/reply_route.hpp).
  transport::Transport& reply_bus(const std::string& robot_id);
  bool deduplicating() const { return config_.map_server.service.reply_voxel_m > 0.0; }
  void start_filling(const MapData& map);
  void warm_cache(const MapData& map);
  void publish_info(int64_t now_us);

  transport::Transport& bus_;
  MapServerNodeConfig config_;
  storage::CloudCache cache_;
  storage::SubmapCloudFiles submap_files_;
  // Guards service_: position queries and updates are handled on the message thread, cloud
  // replies on reply_threads workers.
  mutable std::mutex service_mutex_;
  MapService service_;
  MapSaver saver_;
  std::mutex reply_buses_mutex_;  // guards reply_buses_
  // By URL: at most transport.reply_ports of them, whatever robots ask.
  std::map<std::string, std::unique_ptr<transport::Transport>> reply_buses_;
  int64_t requests_refused_ = 0;     // malformed robot ids (message thread only)
  int64_t descriptor_requests_ = 0;  // answered (message thread only)
  int64_t disk_version_ = 0;
  int64_t saves_failed_ = 0;
  int64_t keyframes_dropped_ = 0;  // refused by a save: never on disk
  storage::SaveReport last_save_;
  int64_t next_info_us_ = 0;
  std::atomic<double> worst_position_reply_ms_{0.0};
  std::atomic<double> worst_cloud_reply_ms_{0.0};
  std::string last_message_;
  std::atomic<bool> stop_filling_{false};
  std::atomic<int64_t> submap_clouds_computed_{0};
  std::thread filler_;
  WorkerPool<CloudRequest> replies_;
};

}  // namespace liloc
