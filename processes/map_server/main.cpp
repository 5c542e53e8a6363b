// liloc_map_server: serves the central session to every robot and grows it.
//   in:  MAP.REQUEST (submap_request_t), MAP.UPDATE (map_update_t)
//   out: <robot>.SUBMAP (submap_t, addressed), MAP.INFO (map_info_t), MAP.STATUS
// Saves merged updates as new map versions in a background thread (atomic, see
// docs/map_format.md), so that serving never waits for the disk.

#include <spdlog/spdlog.h>

#include <atomic>
#include <chrono>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "app/program.hpp"
#include "app/worker_pool.hpp"
#include "bridge/map_conversions.hpp"
#include "bridge/status_report.hpp"
#include "config/yaml_config.hpp"
#include "map/keyframe_descriptors.hpp"
#include "storage/cloud_cache.hpp"
#include "storage/map_error.hpp"
#include "storage/map_store.hpp"
#include "storage/submap_cloud_files.hpp"
#include "system/system_config.hpp"

namespace {
using namespace liloc;
using Clock = std::chrono::steady_clock;

int64_t now_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// Saves map versions one after another on its own thread.
class MapSaver {
 public:
  struct Job {
    MapData map;
    std::map<int64_t, PointCloud> clouds;
  };
  struct Done {
    int64_t version = 0;
    std::vector<int64_t> keyframe_ids;
    std::string error;
  };

  MapSaver(storage::MapStore& store, int64_t version_on_disk, PolarDescriptorConfig descriptor,
           int keep_versions)
      : store_(store),
        version_on_disk_(version_on_disk),
        descriptor_(descriptor),
        keep_(keep_versions) {}

  void submit(Job job) { worker_.submit(std::move(job)); }

  std::vector<Done> take_done() {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<Done> out(done_.begin(), done_.end());
    done_.clear();
    return out;
  }

 private:
  void save(Job& job) {
    // Clouds of a failed save go with the next one, which includes their keyframes.
    job.clouds.insert(unsaved_.begin(), unsaved_.end());
    unsaved_.clear();
    job.map.version = version_on_disk_;
    Done done;
    try {
      const std::map<int64_t, std::vector<uint8_t>> descriptors =
          encode_keyframe_descriptors(job.map.keyframes, job.clouds, descriptor_);
      for (const auto& [id, descriptor] : descriptors) {
        done.keyframe_ids.push_back(id);
      }
      store_.save(job.map, job.clouds, descriptors);
      version_on_disk_ = job.map.version;
      done.version = version_on_disk_;
      store_.prune(keep_);
    } catch (const std::exception& e) {
      done.error = e.what();
      if (done.version == 0) {
        unsaved_ = std::move(job.clouds);
        done.keyframe_ids.clear();
      }
    }
    std::lock_guard<std::mutex> lock(mutex_);
    done_.push_back(std::move(done));
  }

  storage::MapStore& store_;
  int64_t version_on_disk_;
  std::map<int64_t, PointCloud> unsaved_;
  PolarDescriptorConfig descriptor_;
  int keep_;
  std::mutex mutex_;  // guards done_
  std::deque<Done> done_;
  // Last: destroyed first, finishing the queued saves: nothing merged is lost on exit.
  WorkerPool<Job> worker_{[this](Job& job) { save(job); }, WorkerPool<Job>::OnStop::kFinishQueued};
};

class MapServerProcess {
 public:
  MapServerProcess(const SystemConfig& config, storage::MapStore& store, MapData map)
      : config_(config),
        store_(store),
        cache_(store, static_cast<size_t>(config.map_server.cache_mb * 1024 * 1024)),
        submap_files_(store.directory(), config.map_server.service.reply_voxel_m),
        service_(
            std::move(map), [this](int64_t id) { return cache_.get(id); },
            config.map_server.service, deduplicating() ? &submap_files_ : nullptr),
        saver_(store, service_.map().version, config.descriptor, config.map_server.keep_versions),
        bus_(config.transport) {
    disk_version_ = service_.map().version;
    // Requests with clouds are answered off this thread (see service_mutex_).
    bus_.subscribe<liloc::submap_request_t>(
        config.channels.map_request,
        [this](const liloc::submap_request_t& msg, const transport::ReceiveInfo& info) {
          SubmapQuery query = bridge::from_msg(msg);
          if (query.include_clouds) {
            replies_.submit({std::move(query), msg.header.utime, info.recv_utime});
          } else {
            reply(query, msg.header.utime, info.recv_utime);
          }
        });
    bus_.subscribe<liloc::map_update_t>(
        config.channels.map_update,
        [this](const liloc::map_update_t& msg, const transport::ReceiveInfo&) {
          std::optional<MapUpdatePart> part;
          std::string malformed;
          try {
            part = bridge::from_msg(msg);
          } catch (const std::invalid_argument& e) {
            malformed = e.what();
          }
          // Reply workers plan under this lock meanwhile; a merge changes the map.
          std::lock_guard<std::mutex> lock(service_mutex_);
          const UpdateOutcome outcome =
              part ? service_.receive(std::move(*part), now_us())
                   : service_.reject(msg.header.robot_id, msg.update_id, malformed);
          if (outcome.status == UpdateOutcome::Status::kRejected) {
            // Logged the first time and then every 100th: a robot that keeps sending bad
            // updates must not flood the log (all are counted in updates_rejected).
            const int64_t rejected = service_.counters().updates_rejected;
            if (rejected % 100 == 1) {
              spdlog::warn("update {} of {} rejected: {} ({} rejected so far)", msg.update_id,
                           msg.header.robot_id, outcome.reason, rejected);
            }
            last_message_ = "rejected update from " + msg.header.robot_id + ": " + outcome.reason;
          } else if (outcome.status == UpdateOutcome::Status::kMerged) {
            spdlog::info("merged update {} of {}: {} keyframes, {} submaps", msg.update_id,
                         msg.header.robot_id, outcome.new_keyframes.size(),
                         outcome.new_submaps.size());
            saver_.submit({service_.map(), service_.take_new_clouds()});
            ++pending_saves_;
            publish_info();
          }
        });
  }

  ~MapServerProcess() {
    stop_filling_ = true;
    if (filler_.joinable()) {
      filler_.join();
    }
  }

  void run() {
    const MapData& map = service_.map();
    if (deduplicating()) {
      start_filling(map);
    } else {
      warm_cache(map);
    }
    spdlog::info("serving map '{}' version {}: {} keyframes, {} submaps, on {}", map.map_id,
                 map.version, map.keyframes.size(), map.submaps.size(), config_.transport.url);
    Clock::time_point next_info = Clock::now();
    while (!shutdown_requested()) {
      if (bus_.handle(50) < 0) {
        break;
      }
      for (const MapSaver::Done& done : saver_.take_done()) {
        --pending_saves_;
        if (!done.error.empty()) {
          spdlog::error("{}: {}",
                        done.version == 0
                            ? "saving the map failed (merged keyframes kept for the next save)"
                            : "the map was saved but pruning old versions failed",
                        done.error);
          last_message_ = "save: " + done.error;
        }
        if (done.version != 0) {
          disk_version_ = done.version;
          std::lock_guard<std::mutex> lock(service_mutex_);
          service_.saved(done.version, done.keyframe_ids);
          spdlog::info("saved map version {}", done.version);
        }
      }
      if (Clock::now() >= next_info) {
        std::lock_guard<std::mutex> lock(service_mutex_);
        service_.expire(now_us());
        publish_info();
        next_info =
            Clock::now() + std::chrono::duration_cast<Clock::duration>(
                               std::chrono::duration<double>(config_.map_server.info_period_s));
      }
    }
    spdlog::info("stopping: finishing {} pending save(s)", pending_saves_);
  }

 private:
  // Answers one request: planned under the service lock; clouds gathered, encoded and
  // sent without it, so that other requests and updates go on meanwhile.
  // received_us: when the request arrived (LCM's receive time).
  void reply(const SubmapQuery& query, int64_t request_utime, int64_t received_us) {
    transport::Transport* bus = reply_bus(query.reply_url);
    if (bus == nullptr) {
      // Logged the first time and then every 100th, not at every request of a robot.
      if (refused_reply_urls_++ % 100 == 0) {
        spdlog::warn("request {} of {}: reply_url '{}' refused (udpm:// only, at most {} URLs)",
                     query.request_id, query.robot_id, query.reply_url, kMaxReplyBuses);
      }
      return;
    }
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
      bus->publish(channel, message);
    }
    // The worst since the last status, from arrival to the last message sent: what the
    // server adds to a robot's wait, queueing included.
    std::atomic<double>& worst =
        query.include_clouds ? worst_cloud_reply_ms_ : worst_position_reply_ms_;
    const double ms = static_cast<double>(now_us() - received_us) / 1000.0;
    double seen = worst.load();
    while (ms > seen && !worst.compare_exchange_weak(seen, ms)) {
    }
  }

  // The bus a reply goes to: the robot's own (reply_url) if it named one, else the
  // request's. Null for a URL that is not udpm://, or beyond kMaxReplyBuses of them.
  transport::Transport* reply_bus(const std::string& url) {
    if (url.empty()) {
      return &bus_;
    }
    std::lock_guard<std::mutex> lock(reply_buses_mutex_);
    const auto it = reply_buses_.find(url);
    if (it != reply_buses_.end()) {
      return it->second.get();
    }
    if (url.rfind("udpm://", 0) != 0 || reply_buses_.size() >= kMaxReplyBuses) {
      return nullptr;
    }
    transport::TransportConfig reply_config = config_.transport;
    reply_config.url = url;
    reply_config.publish_url.clear();
    try {
      return reply_buses_.emplace(url, std::make_unique<transport::Transport>(reply_config))
          .first->second.get();
    } catch (const std::exception& e) {
      spdlog::warn("reply_url '{}': {}", url, e.what());
      return nullptr;
    }
  }

  bool deduplicating() const { return config_.map_server.service.reply_voxel_m > 0.0; }

  // Computes, in the background, the reply clouds of the submaps that have none on disk
  // yet (a map built by an older liloc_map, or other tools), so that requests find them.
  void start_filling(const MapData& map) {
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

  // Loads keyframe clouds until the cache is three quarters full, so that the first
  // requests are answered from memory; a map beyond the cache is served from disk.
  void warm_cache(const MapData& map) {
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

  void publish_info() {
    liloc::map_info_t info = bridge::to_msg(service_.map(), service_.counters(), now_us());
    bus_.publish(config_.channels.map_info, info);
    bridge::StatusReport report;
    report.process = "map_server";
    const MapServiceCounters& c = service_.counters();
    report.timings_ms = {
        {"position_reply_max", static_cast<float>(worst_position_reply_ms_.exchange(0.0))},
        {"cloud_reply_max", static_cast<float>(worst_cloud_reply_ms_.exchange(0.0))}};
    report.counters = {{"requests", c.requests},
                       {"empty_replies", c.empty_replies},
                       {"updates_merged", c.updates_merged},
                       {"updates_rejected", c.updates_rejected},
                       {"updates_expired", c.updates_expired},
                       {"keyframes_merged", c.keyframes_merged},
                       {"map_version", disk_version_},
                       {"pending_saves", pending_saves_},
                       {"cache_bytes", static_cast<int64_t>(cache_.bytes())},
                       {"cache_hits", cache_.hits()},
                       {"cache_misses", cache_.misses()},
                       {"refused_reply_urls", refused_reply_urls_.load()},
                       {"submap_clouds_computed", submap_clouds_computed_.load()},
                       {"submap_cloud_files_damaged", submap_files_.damaged()},
                       {"submap_cloud_store_errors", service_.store_errors()}};
    report.add_transport_counters(bus_);
    report.message = last_message_;
    liloc::status_t status = bridge::to_msg(report, now_us(), "map_server");
    bus_.publish(config_.map_server.status_channel, status);
  }

  SystemConfig config_;
  storage::MapStore& store_;
  storage::CloudCache cache_;
  storage::SubmapCloudFiles submap_files_;
  MapService service_;
  MapSaver saver_;
  transport::Transport bus_;
  static constexpr size_t kMaxReplyBuses = 64;
  std::mutex reply_buses_mutex_;                                              // guards reply_buses_
  std::map<std::string, std::unique_ptr<transport::Transport>> reply_buses_;  // by URL
  std::atomic<int64_t> refused_reply_urls_{0};
  int64_t disk_version_ = 0;
  int pending_saves_ = 0;
  std::atomic<double> worst_position_reply_ms_{0.0};
  std::atomic<double> worst_cloud_reply_ms_{0.0};
  std::string last_message_;
  std::atomic<bool> stop_filling_{false};
  std::atomic<int64_t> submap_clouds_computed_{0};
  std::thread filler_;
  // Guards service_: position queries and updates are handled on the LCM thread, cloud
  // replies (hundreds of kB to read and send) on reply_threads workers, so that they
  // never hold up the small ones and a burst of them (robots entering submaps at once) is
  // answered side by side.
  std::mutex service_mutex_;
  struct CloudRequest {
    SubmapQuery query;
    int64_t request_utime = 0;
    int64_t received_us = 0;
  };
  WorkerPool<CloudRequest> replies_{
      [this](CloudRequest& r) {
        try {
          reply(r.query, r.request_utime, r.received_us);
        } catch (const std::exception& e) {
          spdlog::error("reply to {} request {}: {}", r.query.robot_id, r.query.request_id,
                        e.what());
        }
      },
      WorkerPool<CloudRequest>::OnStop::kDropQueued, config_.map_server.reply_threads};
};
}  // namespace

int main(int argc, char** argv) {
  std::string config_path = "config/liloc.yaml";
  std::string map_directory;
  std::string url;
  bool print_config = false;
  CommandLine cli("liloc_map_server", "Serves the central session's submaps to every robot.");
  cli.add_option("config", &config_path, "system config (YAML)");
  cli.add_option("map", &map_directory, "map directory, overrides map_server.map_directory");
  cli.add_option("lcm-url", &url, "LCM URL, overrides the config");
  cli.add_flag("print-config", &print_config, "print the effective config and exit");
  return run_program(cli, "map_server", argc, argv, [&]() -> int {
    SystemConfig config = load_config<SystemConfig>(config_path);
    if (!map_directory.empty()) {
      config.map_server.map_directory = map_directory;
    }
    if (!url.empty()) {
      config.transport.url = url;
    }
    if (print_config) {
      std::printf("%s\n", dump_config(config).c_str());
      return 0;
    }
    storage::MapStore store(config.map_server.map_directory);
    if (!store.exists()) {
      throw std::runtime_error(config.map_server.map_directory +
                               ": no map (build one with liloc_map build)");
    }
    MapData map = store.load();  // a damaged map stops here, naming the file
    MapServerProcess process(config, store, std::move(map));
    process.run();
    return 0;
  });
}
