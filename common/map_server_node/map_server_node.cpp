#include "map_server_node/map_server_node.hpp"

#include <spdlog/spdlog.h>

#include <chrono>
#include <optional>

#include "app/program.hpp"
#include "app/rate_limit.hpp"
#include "bridge/map_conversions.hpp"
#include "bridge/status_report.hpp"
#include "map/map_validation.hpp"
#include "node/reply_route.hpp"

namespace liloc {
namespace {
using Clock = std::chrono::steady_clock;

// Raises `worst` to `ms` if that is larger (from any thread).
void keep_worst(std::atomic<double>& worst, double ms) {
  double seen = worst.load();
  while (ms > seen && !worst.compare_exchange_weak(seen, ms)) {
  }
}
}  // namespace

void MapServerConfig::validate() const {
  if (!(cache_mb > 0.0 && cache_mb <= 1e6) || !(info_period_s > 0.0 && info_period_s <= 3600.0)) {
    throw std::invalid_argument(
        "cache_mb must be in (0, 1e6] (a terabyte) and info_period_s in (0, 3600]");
  }
  if (keep_versions < 1) {
    throw std::invalid_argument("keep_versions must be at least 1");
  }
  if (reply_threads < 1 || reply_threads > 64) {
    throw std::invalid_argument("reply_threads must be 1 to 64, got " +
                                std::to_string(reply_threads));
  }
}

MapServerNode::MapServerNode(transport::Transport& bus, const MapServerNodeConfig& config,
                             storage::MapStore& store, MapData map)
    : bus_(bus),
      config_(config),
      cache_(store, static_cast<size_t>(config.map_server.cache_mb * 1024 * 1024)),
      submap_files_(store.directory(), config.map_server.service.reply_voxel_m),
      service_(
          map, [this](int64_t id) { return cache_.get(id); }, load_descriptors(store, map),
          config.map_server.service, config.submaps, config.descriptor,
          deduplicating() ? &submap_files_ : nullptr),
      saver_(store, map, config.map_server.keep_versions),
      disk_version_(map.version),
      replies_(
          [this](CloudRequest& r) {
            try {
              reply(r.query, r.request_utime, r.received_us);
            } catch (const std::exception& e) {
              spdlog::error("reply to {} request {}: {}", r.query.robot_id, r.query.request_id,
                            e.what());
            }
          },
          WorkerPool<CloudRequest>::OnStop::kDropQueued, config.map_server.reply_threads) {
  config_.map_server.validate();
  // Requests with clouds are answered off this thread (see service_mutex_).
  bus_.subscribe<liloc::submap_request_t>(
      config.channels.map_request,
      [this](const liloc::submap_request_t& msg, const transport::ReceiveInfo& info) {
        SubmapQuery query = bridge::from_msg(msg);
        if (!is_valid_name(query.robot_id)) {
          // Its reply channel and port come from its id: a malformed one names neither.
          if (should_log(++requests_refused_)) {
            spdlog::warn("request from robot '{}' refused: not a valid robot id ({} so far)",
                         printable_excerpt(query.robot_id), requests_refused_);
          }
          return;
        }
        if (query.include_clouds) {
          replies_.submit({std::move(query), msg.header.utime, info.recv_utime});
        } else {
          reply(query, msg.header.utime, info.recv_utime);
        }
      });
  bus_.subscribe<liloc::descriptor_request_t>(
      config.channels.descriptor_request,
      [this](const liloc::descriptor_request_t& msg, const transport::ReceiveInfo&) {
        on_descriptor_request(bridge::from_msg(msg));
      });
  bus_.subscribe<liloc::map_update_t>(
      config.channels.map_update,
      [this](const liloc::map_update_t& msg, const transport::ReceiveInfo&) {
        on_update(bridge::receive_update(msg));
      });
  if (deduplicating()) {
    start_filling(map);
  } else {
    warm_cache(map);
  }
  spdlog::info("serving map '{}' version {}: {} keyframes, {} submaps", map.map_id, map.version,
               map.keyframes.size(), map.submaps.size());
}

MapServerNode::~MapServerNode() {
  stop_filling_ = true;
  if (filler_.joinable()) {
    filler_.join();
  }
}

MapData MapServerNode::map() const {
  std::lock_guard<std::mutex> lock(service_mutex_);
  return service_.map();
}

KeyframeDescriptors MapServerNode::load_descriptors(const storage::MapStore& store,
                                                    const MapData& map) {
  // Computed when the map was built and kept beside its clouds: no request recomputes them.
  KeyframeDescriptors out;
  int64_t unreadable = 0;
  std::string first_error;
  for (const MapKeyframe& kf : map.keyframes) {
    try {
      out[kf.id] = store.load_descriptor(kf.id);
    } catch (const std::exception& e) {
      first_error = first_error.empty() ? e.what() : first_error;
      ++unreadable;
    }
  }
  if (unreadable > 0) {
    spdlog::error(
        "{} keyframe descriptor(s) unreadable, those keyframes are not searched by "
        "initialization; the first: {}",
        unreadable, first_error);
  }
  return out;
}

void MapServerNode::on_descriptor_request(const bridge::DescriptorRequest& request) {
  if (!is_valid_name(request.robot_id)) {
    if (should_log(++requests_refused_)) {
      spdlog::warn("descriptor request from robot '{}' refused: not a valid robot id",
                   printable_excerpt(request.robot_id));
    }
    return;
  }
  std::vector<KeyframeIndexPart> parts;
  {
    std::lock_guard<std::mutex> lock(service_mutex_);
    parts = service_.keyframe_index(request.robot_id, request.request_id);
  }
  transport::Transport& bus = reply_bus(request.robot_id);
  const std::string channel =
      transport::robot_channel(request.robot_id, config_.channels.descriptors);
  for (const KeyframeIndexPart& part : parts) {
    liloc::keyframe_descriptors_t reply = bridge::to_msg(part, request.utime_us);
    bus.publish(channel, reply);
  }
  ++descriptor_requests_;
}

void MapServerNode::on_update(bridge::ReceivedMapUpdate update) {
  UpdateOutcome outcome;
  MapDelta merged;
  int64_t rejected = 0;
  {
    // Reply workers plan under this lock meanwhile; a merge changes the map.
    std::lock_guard<std::mutex> lock(service_mutex_);
    outcome = update.part ? service_.receive(std::move(*update.part), node::wall_clock_us())
                          : service_.reject(update.robot_id, update.session_id, update.update_id,
                                            update.malformed);
    if (outcome.status == UpdateOutcome::Status::kMerged) {
      merged = service_.take_unsaved();
    }
    rejected = service_.counters().updates_rejected;
  }
  if (outcome.status == UpdateOutcome::Status::kRejected) {
    // Logged the first time and then every 100th: a robot that keeps sending bad updates
    // must not flood the log (all are counted in updates_rejected).
    if (rejected % 100 == 1) {
      spdlog::warn("update {} of {} rejected: {} ({} rejected so far)", update.update_id,
                   update.robot_id, outcome.reason, rejected);
    }
    last_message_ = "rejected update from " + update.robot_id + ": " + outcome.reason;
  } else if (outcome.status == UpdateOutcome::Status::kMerged) {
    spdlog::info("merged update {} of {}: {} keyframes, {} submaps", update.update_id,
                 update.robot_id, outcome.new_keyframes.size(), outcome.new_submaps.size());
    saver_.submit(std::move(merged));
    publish_info(node::wall_clock_us());
  }
}

void MapServerNode::tick(int64_t now_us) {
  take_save_results();
  if (now_us >= next_info_us_) {
    {
      std::lock_guard<std::mutex> lock(service_mutex_);
      service_.expire(now_us);
    }
    saver_.retry();  // what a failed save kept, once per info period
    publish_info(now_us);
    next_info_us_ = now_us + static_cast<int64_t>(config_.map_server.info_period_s * 1e6);
  }
}

void MapServerNode::take_save_results() {
  for (const MapSaver::Result& done : saver_.take_results()) {
    if (!done.error.empty()) {
      spdlog::error("{}: {}",
                    done.version == 0 ? "saving the map failed (merged keyframes kept for the "
                                        "next save unless dropped)"
                                      : "saving the map",
                    done.error);
      last_message_ = "save: " + done.error;
      saves_failed_ += done.version == 0 ? 1 : 0;
    }
    keyframes_dropped_ += done.dropped_keyframes;
    if (done.version != 0) {
      disk_version_ = done.version;
      last_save_ = done.report;
      std::lock_guard<std::mutex> lock(service_mutex_);
      service_.saved(done.version, done.keyframe_ids);
      spdlog::info("saved map version {} ({} keyframe files, {:.0f} ms)", done.version,
                   done.report.keyframe_files_written, done.report.total_ms);
    }
  }
}

bool MapServerNode::finish() {
  stop_filling_ = true;
  const int64_t unsaved_before = saver_.unsaved_keyframes();
  spdlog::info("stopping: finishing the saves of {} merged keyframe(s)", unsaved_before);
  const int64_t unsaved = saver_.finish();
  take_save_results();
  if (unsaved > 0 || keyframes_dropped_ > 0) {
    spdlog::error("{} merged keyframe(s) could not be saved and are lost, {} dropped by a save",
                  unsaved, keyframes_dropped_);
    return false;
  }
  return true;
}

void MapServerNode::reply(const SubmapQuery& query, int64_t request_utime, int64_t received_us) {
  transport::Transport& bus = reply_bus(query.robot_id);
  MapService::ReplyPlan plan;
  {
    std::lock_guard<std::mutex> lock(service_mutex_);
    plan = service_.plan(query);
  }
  const std::vector<SubmapReplyPart> parts = service_.complete(plan);
  {
    std::lock_guard<std::mutex> lock(service_mutex_);
    service_.remember(plan);
  }
  const std::string channel = transport::robot_channel(query.robot_id, config_.channels.submap);
  for (const SubmapReplyPart& part : parts) {
    liloc::submap_t message = bridge::to_msg(part, request_utime);
    bus.publish(channel, message);
  }
  // The worst since the last status, from arrival to the last message sent: what the
  // server adds to a robot's wait, queueing included.
  keep_worst(query.include_clouds ? worst_cloud_reply_ms_ : worst_position_reply_ms_,
             static_cast<double>(node::wall_clock_us() - received_us) / 1000.0);
}

transport::Transport& MapServerNode::reply_bus(const std::string& robot_id) {
  // The server picks the destination from its config and the robot id (node/reply_route);
  // a request's reply_url field is ignored, so no wire field chooses where it sends.
  const std::string url = node::reply_url(bus_.config().url, bus_.config().reply_ports, robot_id);
  if (url == bus_.config().url) {
    return bus_;
  }
  std::lock_guard<std::mutex> lock(reply_buses_mutex_);
  std::unique_ptr<transport::Transport>& bus = reply_buses_[url];  // reply_ports at most
  if (!bus) {
    transport::TransportConfig reply_config = bus_.config();
    reply_config.url = url;
    reply_config.publish_url.clear();
    bus = std::make_unique<transport::Transport>(reply_config);
  }
  return *bus;
}

void MapServerNode::start_filling(const MapData& map) {
  // Computes, in the background, the reply clouds of the submaps that have none on disk
  // yet (a map built by an older liloc_map, or other tools), so that requests find them.
  filler_ = std::thread([this, map] {
    const Clock::time_point start = Clock::now();
    try {
      const int computed = fill_submap_cloud_store(
          map, [this](int64_t id) { return cache_.get(id); }, submap_files_,
          [this] { return stop_filling_.load() || shutdown_requested(); });
      submap_clouds_computed_ = computed;
      spdlog::info("submap reply clouds: {} of {} computed in {:.1f} s, the others on disk",
                   computed, map.submaps.size(),
                   std::chrono::duration<double>(Clock::now() - start).count());
    } catch (const std::exception& e) {
      spdlog::error("computing submap reply clouds: {} (requests compute them)", e.what());
    }
  });
}

void MapServerNode::warm_cache(const MapData& map) {
  // Loads keyframe clouds until the cache is three quarters full, so that the first
  // requests are answered from memory; a map beyond the cache is served from disk.
  const Clock::time_point start = Clock::now();
  for (const MapKeyframe& kf : map.keyframes) {
    if (cache_.bytes() * 4 >= cache_.max_bytes() * 3 || shutdown_requested()) {
      break;
    }
    cache_.get(kf.id);
  }
  spdlog::info("cache warm: {} MB of clouds in {:.1f} s", cache_.bytes() / (1024 * 1024),
               std::chrono::duration<double>(Clock::now() - start).count());
}

void MapServerNode::publish_info(int64_t now_us) {
  bridge::StatusReport report;
  {
    std::lock_guard<std::mutex> lock(service_mutex_);
    liloc::map_info_t info = bridge::to_msg(service_.map(), service_.counters(), now_us);
    bus_.publish(config_.channels.map_info, info);
    const MapServiceCounters& c = service_.counters();
    report.counters = {{"requests", c.requests},
                       {"empty_replies", c.empty_replies},
                       {"updates_merged", c.updates_merged},
                       {"updates_rejected", c.updates_rejected},
                       {"updates_refused_robot", c.updates_refused_robot},
                       {"updates_refused_busy", c.updates_refused_busy},
                       {"updates_repeated", c.updates_repeated},
                       {"updates_pending", static_cast<int64_t>(service_.pending_updates())},
                       {"updates_expired", c.updates_expired},
                       {"keyframes_merged", c.keyframes_merged},
                       {"submap_cloud_store_errors", service_.store_errors()}};
  }
  report.process = "map_server";
  report.timings_ms = {
      {"position_reply_max", static_cast<float>(worst_position_reply_ms_.exchange(0.0))},
      {"cloud_reply_max", static_cast<float>(worst_cloud_reply_ms_.exchange(0.0))},
      {"save_check", static_cast<float>(last_save_.check_ms)},
      {"save_keyframe_files", static_cast<float>(last_save_.keyframe_files_ms)},
      {"save_version", static_cast<float>(last_save_.version_ms)},
      {"save_commit", static_cast<float>(last_save_.commit_ms)},
      {"save_total", static_cast<float>(last_save_.total_ms)}};
  const std::vector<std::pair<std::string, int64_t>> more = {
      {"requests_refused", requests_refused_},
      {"descriptor_requests", descriptor_requests_},
      {"map_version", disk_version_},
      {"unsaved_keyframes", saver_.unsaved_keyframes()},
      {"saves_failed", saves_failed_},
      {"keyframes_dropped", keyframes_dropped_},
      {"cache_bytes", static_cast<int64_t>(cache_.bytes())},
      {"cache_hits", cache_.hits()},
      {"cache_misses", cache_.misses()},
      {"submap_clouds_computed", submap_clouds_computed_.load()},
      {"submap_cloud_files_damaged", submap_files_.damaged()}};
  report.counters.insert(report.counters.end(), more.begin(), more.end());
  report.add_transport_counters(bus_);
  report.message = last_message_;
  liloc::status_t status = bridge::to_msg(report, now_us, "map_server");
  bus_.publish(config_.map_server.status_channel, status);
}

}  // namespace liloc
