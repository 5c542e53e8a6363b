// bench_mapserver: many robots asking one liloc_map_server for submaps over loopback UDP
// multicast, as in the field: every robot sends a position query (poses and bounds) at
// the request rate while it drives along the map's path, and asks for a submap's clouds
// when it enters that submap. Measured per map size (the map as given, and tiled N
// times): reply latency from request to the last message of the reply, lost replies
// (requests whose reply is incomplete 2 s after the run), the server's own worst reply
// times (MAP.STATUS), its memory, and the CPU time the hypervisor stole meanwhile. With
// --echo-baseline each run is preceded by one against a stand-in that answers at once:
// the machine's floor. Writes bench/results/mapserver.json with robots, requests_per_s,
// reply_ms_p50, reply_ms_p99, lost_replies and server_rss_mb per run; map_ate_m comes
// from the `liloc_map build --json` reports passed with --map-reports.

#include <signal.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "app/child_process.hpp"
#include "app/process_memory.hpp"
#include "app/program.hpp"
#include "bridge/map_conversions.hpp"
#include "config/yaml_config.hpp"
#include "eval/json_writer.hpp"
#include "eval/latency_stats.hpp"
#include "liloc/status_t.hpp"
#include "map/submap_database.hpp"
#include "node/reply_route.hpp"
#include "storage/file_io.hpp"
#include "storage/map_store.hpp"
#include "storage/submap_cloud_files.hpp"
#include "system/system_config.hpp"
#include "transport/channels.hpp"
#include "transport/transport.hpp"

namespace {
using namespace liloc;
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

// The map repeated `copies` times side by side along x (ids renumbered), written to dir:
// a bigger map of the same density.
void write_tiled_map(const std::string& source_dir, const std::string& dir, int copies) {
  storage::MapStore source(source_dir);
  const MapData map = source.load();
  double min_x = 1e18, max_x = -1e18;
  for (const MapKeyframe& kf : map.keyframes) {
    min_x = std::min(min_x, kf.T_map_body.translation().x());
    max_x = std::max(max_x, kf.T_map_body.translation().x());
  }
  const double pitch_m = max_x - min_x + 200.0;  // clouds reach ~100 m beyond the path
  const int64_t id_step = map.keyframes.back().id + 1;
  MapData tiled;
  tiled.map_id = map.map_id + "-x" + std::to_string(copies);
  std::map<int64_t, PointCloud> clouds;
  std::map<int64_t, std::vector<uint8_t>> descriptors;
  for (int c = 0; c < copies; ++c) {
    for (MapKeyframe kf : map.keyframes) {
      clouds[kf.id + c * id_step] = source.load_cloud(kf.id);
      descriptors[kf.id + c * id_step] = source.load_descriptor(kf.id);
      kf.id += c * id_step;
      kf.T_map_body.translation().x() += c * pitch_m;
      tiled.keyframes.push_back(kf);
    }
    for (PoseGraphEdge e : map.edges) {
      e.from += c * id_step;
      e.to += c * id_step;
      tiled.edges.push_back(e);
    }
  }
  tiled.submaps = join_submaps(tiled.keyframes, SubmapConfig{}, 0);
  storage::MapStore(dir).save(tiled, clouds, descriptors);
}

// The submaps' reply clouds on disk before the server starts, as `liloc_map build` leaves
// them, so that the runs measure serving, not the one-time deduplication.
void prepare_reply_clouds(const std::string& map_dir, const std::string& config_path) {
  const double voxel_m = load_config<SystemConfig>(config_path).map_server.service.reply_voxel_m;
  const Clock::time_point start = Clock::now();
  storage::MapStore store(map_dir);
  const int computed = fill_submap_cloud_store(
      store.load(),
      [&store](int64_t id) { return std::make_shared<const PointCloud>(store.load_cloud(id)); },
      storage::SubmapCloudFiles(map_dir, voxel_m));
  spdlog::info("{}: {} submap reply clouds computed in {:.1f} s", map_dir, computed,
               std::chrono::duration<double>(Clock::now() - start).count());
}

// Runs `work` in a child process and waits for it. Writing a tiled map holds all its clouds
// (gigabytes) at once; in this process the heap it leaves behind slowed the robots' reply
// decoding measurably (10x map: reply p99 37-44 ms right after writing, 24 ms when the same
// map was served by a fresh process).
void in_child_process(const std::function<void()>& work) {
  if (ChildProcess(work).wait(3600.0) != 0) {
    throw std::runtime_error("preparing the map in a child process failed");
  }
}

// A stand-in for the server that answers every request at once with one small message
// (no submap, no clouds), on the robot's reply route as the server computes it: what LCM
// request and reply cost on this machine at this moment, the floor under the server's
// latency. Runs until SIGINT.
void run_echo_server(const std::string& url, int reply_ports) {
  transport::TransportConfig config;
  config.url = url;
  transport::Transport bus(config);
  std::map<std::string, std::unique_ptr<transport::Transport>> reply_buses;
  bus.subscribe<liloc::submap_request_t>(
      transport::ChannelConfig{}.map_request,
      [&](const liloc::submap_request_t& msg, const transport::ReceiveInfo&) {
        transport::Transport* reply_bus = &bus;
        const std::string reply_url = node::reply_url(url, reply_ports, msg.header.robot_id);
        if (reply_url != url) {
          std::unique_ptr<transport::Transport>& b = reply_buses[reply_url];
          if (!b) {
            transport::TransportConfig reply_config;
            reply_config.url = reply_url;
            b = std::make_unique<transport::Transport>(reply_config);
          }
          reply_bus = b.get();
        }
        SubmapReplyPart part;
        part.robot_id = msg.header.robot_id;
        part.request_id = msg.request_id;
        part.reply_count = 1;
        liloc::submap_t reply = bridge::to_msg(part, msg.header.utime);
        reply_bus->publish(transport::robot_channel(part.robot_id, "SUBMAP"), reply);
      });
  while (!shutdown_requested()) {
    bus.handle(100);
  }
}

// The machine's CPU time (/proc/stat): the share the hypervisor stole from this virtual
// machine during a run, which moves latency tails here more than anything in liloc.
struct CpuTimes {
  int64_t steal = 0;
  int64_t total = 0;
};

CpuTimes read_cpu_times() {
  std::ifstream in("/proc/stat");
  std::string cpu;
  int64_t value = 0;
  CpuTimes t;
  in >> cpu;
  for (int field = 0; field < 8 && in >> value; ++field) {
    t.total += value;  // user nice system idle iowait irq softirq steal
    if (field == 7) {
      t.steal = value;
    }
  }
  return t;
}

struct RobotResult {
  std::vector<double> position_reply_ms;
  std::vector<double> cloud_reply_ms;
  int64_t requests = 0;
  int64_t lost = 0;
  int64_t bytes = 0;
};

// One robot: its own LCM instance, driving along the map's keyframe path from `start`.
class Robot {
 public:
  // reply_url: where the server sends its replies (node/reply_route.hpp): a port of the
  // robot's own, or the bus.
  Robot(const std::string& robot_id, const std::string& url, const std::string& reply_url,
        const std::vector<Eigen::Vector3d>& path, size_t start)
      : id_(robot_id), path_(path), index_(start) {
    transport::TransportConfig config;
    config.url = url;
    bus_ = std::make_unique<transport::Transport>(config);
    if (reply_url != url) {
      config.url = reply_url;
      reply_bus_ = std::make_unique<transport::Transport>(config);
    }
    receiver().subscribe<liloc::submap_t>(
        transport::robot_channel(id_, "SUBMAP"),
        [this](const liloc::submap_t& msg, const transport::ReceiveInfo& info) {
          on_reply(msg, info);
        });
  }

  // Sends one request and waits for its reply, up to timeout: true once answered.
  bool ping(double timeout_s) {
    send(false, -1);
    const Clock::time_point end = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                     std::chrono::duration<double>(timeout_s));
    while (Clock::now() < end && !pending_.empty()) {
      receiver().handle(50);
    }
    const bool answered = pending_.empty();
    pending_.clear();
    result_ = {};
    return answered;
  }

  void run(double rate_hz, double duration_s) {
    const auto period =
        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate_hz));
    const Clock::time_point end = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                     std::chrono::duration<double>(duration_s));
    Clock::time_point next = Clock::now();
    while (next < end) {
      // Entering a new submap: fetch its clouds (this tick's request), else where am I.
      if (current_submap_ != fetched_submap_ && current_submap_ >= 0) {
        send(true, current_submap_);
        fetched_submap_ = current_submap_;
      } else {
        send(false, -1);
      }
      index_ = (index_ + 1) % path_.size();
      next += period;
      while (Clock::now() < next) {
        const auto left =
            std::chrono::duration_cast<std::chrono::milliseconds>(next - Clock::now());
        receiver().handle(static_cast<int>(std::max<int64_t>(1, left.count())));
      }
    }
    const Clock::time_point drain_end = Clock::now() + std::chrono::seconds(2);
    while (Clock::now() < drain_end && !pending_.empty()) {
      receiver().handle(50);
    }
    result_.lost = static_cast<int64_t>(pending_.size());
  }

  const RobotResult& result() const { return result_; }

 private:
  struct Pending {
    Clock::time_point sent;
    bool clouds = false;
    int received = 0;
  };

  void send(bool clouds, int64_t submap_id) {
    SubmapQuery q;
    q.robot_id = id_;
    q.request_id = ++request_id_;
    q.by_id = clouds;
    if (clouds) {
      q.submap_ids = {submap_id};
    }
    q.position = path_[index_];
    q.include_clouds = clouds;
    pending_[q.request_id] = {Clock::now(), clouds, 0};
    liloc::submap_request_t msg = bridge::to_msg(q, 0);
    bus_->publish(transport::ChannelConfig{}.map_request, msg);
    ++result_.requests;
  }

  void on_reply(const liloc::submap_t& msg, const transport::ReceiveInfo& info) {
    const auto it = pending_.find(msg.request_id);
    if (it == pending_.end()) {
      return;
    }
    result_.bytes += info.bytes;
    if (!it->second.clouds && msg.submap_id >= 0) {
      current_submap_ = msg.submap_id;
    }
    if (++it->second.received == msg.reply_count) {
      const double ms =
          std::chrono::duration<double, std::milli>(Clock::now() - it->second.sent).count();
      (it->second.clouds ? result_.cloud_reply_ms : result_.position_reply_ms).push_back(ms);
      pending_.erase(it);
    }
  }

  transport::Transport& receiver() { return reply_bus_ ? *reply_bus_ : *bus_; }

  std::string id_;
  std::vector<Eigen::Vector3d> path_;
  size_t index_;
  std::unique_ptr<transport::Transport> bus_;        // requests (and replies without reply_url)
  std::unique_ptr<transport::Transport> reply_bus_;  // the robot's own group, if any
  std::map<int64_t, Pending> pending_;
  int64_t request_id_ = 0;
  int64_t current_submap_ = -1;
  int64_t fetched_submap_ = -1;
  RobotResult result_;
};

// The server's own account (MAP.STATUS, once a second): the worst time from a request's
// arrival to its reply's last message, per kind, over the run. Against the robots'
// latency this tells the server's share from the transport's and the robots'.
class ServerStatusListener {
 public:
  ServerStatusListener(const std::string& url, const std::string& channel) {
    transport::TransportConfig config;
    config.url = url;
    bus_ = std::make_unique<transport::Transport>(config);
    bus_->subscribe<liloc::status_t>(
        channel, [this](const liloc::status_t& msg, const transport::ReceiveInfo&) {
          for (int32_t i = 0; i < msg.num_timings; ++i) {
            if (msg.timing_names[i] == "position_reply_max") {
              raise(worst_position_ms_, msg.timing_ms[i]);
            } else if (msg.timing_names[i] == "cloud_reply_max") {
              raise(worst_cloud_ms_, msg.timing_ms[i]);
            }
          }
        });
    thread_ = std::thread([this] {
      while (!stop_) {
        bus_->handle(50);
      }
    });
  }
  ~ServerStatusListener() {
    stop_ = true;
    thread_.join();
  }
  // Forgets what was seen so far (the warm-up before the run). The server's window ends
  // at each status, so wait one period after the warm-up's last request first.
  void reset() {
    worst_position_ms_ = 0.0;
    worst_cloud_ms_ = 0.0;
  }
  double worst_position_ms() const { return worst_position_ms_; }
  double worst_cloud_ms() const { return worst_cloud_ms_; }

 private:
  static void raise(std::atomic<double>& worst, double ms) {
    double seen = worst.load();
    while (ms > seen && !worst.compare_exchange_weak(seen, ms)) {
    }
  }

  std::unique_ptr<transport::Transport> bus_;
  std::atomic<double> worst_position_ms_{0.0};
  std::atomic<double> worst_cloud_ms_{0.0};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// What every run of the bench shares (its command line).
struct BenchOptions {
  std::string server_path = "build/bin/liloc_map_server";
  std::string config_path = "config/liloc.yaml";
  std::string url = "udpm://239.255.76.67:7691?ttl=0&recv_buf_size=4194304";
  bool reply_groups = true;  // replies on a port per robot (transport.reply_ports)
  int robots = 8;
  double rate_hz = 10.0;
  double duration_s = 60.0;
};

struct Run {
  bool echo = false;  // the echo stand-in, not the server
  int map_copies = 1;
  size_t keyframes = 0;
  size_t submaps = 0;
  int robots = 0;
  bool reply_groups = false;  // replies on a port per robot (transport.reply_ports)
  double requests_per_s = 0.0;
  eval::LatencyStats all, position, clouds;
  int64_t lost = 0;
  double mb_per_s = 0.0;
  ProcessMemory server;
  double server_worst_position_ms = 0.0;  // MAP.STATUS
  double server_worst_cloud_ms = 0.0;
  double steal_percent = 0.0;  // of the machine's CPU time during the run
};

Run run_once(const BenchOptions& options, const std::string& map_dir, int copies, bool echo) {
  const std::string& url = options.url;
  storage::MapStore store(map_dir);
  const MapData map = store.load();
  std::vector<Eigen::Vector3d> path;
  for (const MapKeyframe& kf : map.keyframes) {
    path.push_back(kf.T_map_body.translation());
  }
  // The server's config as given, but for where its replies go.
  SystemConfig config = load_config<SystemConfig>(options.config_path);
  config.transport.reply_ports = options.reply_groups ? config.transport.reply_ports : 0;
  const std::string config_path = fs::temp_directory_path().string() + "/bench_mapserver_" +
                                  std::to_string(::getpid()) + ".yaml";
  std::ofstream(config_path) << dump_config(config) << "\n";
  const int reply_ports = config.transport.reply_ports;
  const std::unique_ptr<ChildProcess> server =
      echo ? std::make_unique<ChildProcess>([&] { run_echo_server(url, reply_ports); })
           : std::make_unique<ChildProcess>(
                 options.server_path,
                 std::vector<std::string>{"--config", config_path, "--map", map_dir, "--lcm-url",
                                          url, "--log-level", "warn"});
  ServerStatusListener status(url, config.map_server.status_channel);
  std::vector<std::unique_ptr<Robot>> fleet;
  for (int r = 0; r < options.robots; ++r) {
    const std::string id = "bench" + std::to_string(r);
    const std::string reply_url = node::reply_url(url, reply_ports, id);
    fleet.push_back(std::make_unique<Robot>(id, url, reply_url, path,
                                            path.size() * static_cast<size_t>(r) / options.robots));
  }
  // The server is up when it answers.
  bool up = false;
  for (int attempt = 0; attempt < 60 && !up; ++attempt) {
    up = fleet.front()->ping(1.0);
  }
  if (!up) {
    throw std::runtime_error("liloc_map_server did not answer within 60 s on " + url);
  }
  std::vector<std::thread> threads;
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // a status after the warm-up
  status.reset();
  const CpuTimes cpu_before = read_cpu_times();
  const Clock::time_point start = Clock::now();
  for (auto& robot : fleet) {
    threads.emplace_back([&robot, &options] { robot->run(options.rate_hz, options.duration_s); });
  }
  for (std::thread& t : threads) {
    t.join();
  }
  const double elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
  const CpuTimes cpu_after = read_cpu_times();
  Run run;
  run.echo = echo;
  run.steal_percent = 100.0 * static_cast<double>(cpu_after.steal - cpu_before.steal) /
                      static_cast<double>(std::max<int64_t>(1, cpu_after.total - cpu_before.total));
  run.server = read_process_memory(std::to_string(server->pid()));
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // the last status
  run.server_worst_position_ms = status.worst_position_ms();
  run.server_worst_cloud_ms = status.worst_cloud_ms();
  server->stop(SIGINT, 30.0);
  fs::remove(config_path);

  run.map_copies = copies;
  run.keyframes = map.keyframes.size();
  run.submaps = map.submaps.size();
  run.robots = options.robots;
  run.reply_groups = options.reply_groups;
  std::vector<double> all, position, clouds;
  int64_t requests = 0, bytes = 0;
  for (const auto& robot : fleet) {
    const RobotResult& r = robot->result();
    position.insert(position.end(), r.position_reply_ms.begin(), r.position_reply_ms.end());
    clouds.insert(clouds.end(), r.cloud_reply_ms.begin(), r.cloud_reply_ms.end());
    requests += r.requests;
    bytes += r.bytes;
    run.lost += r.lost;
  }
  all = position;
  all.insert(all.end(), clouds.begin(), clouds.end());
  run.requests_per_s = requests / elapsed_s;
  run.mb_per_s = bytes / elapsed_s / 1e6;
  const auto stats = [](const std::vector<double>& ms) {
    return ms.empty() ? eval::LatencyStats{} : eval::compute_latency_stats(ms);
  };
  run.all = stats(all);
  run.position = stats(position);
  run.clouds = stats(clouds);
  return run;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args;
  BenchOptions options;
  std::string scales_text = "1,10";
  std::string scratch = "data/bench_mapserver";
  std::string map_reports;
  std::string json_path = "bench/results/mapserver.json";
  bool shared_group = false;
  bool echo_baseline = false;
  int repeats = 1;
  CommandLine cli("bench_mapserver",
                  "Robots requesting submaps from liloc_map_server over loopback: latency, "
                  "lost replies, server memory, for the map and a tiled bigger one.");
  cli.add_positional("MAP_DIR", &args, "a map directory (liloc_map build)", 1);
  cli.add_option("server", &options.server_path, "the liloc_map_server binary");
  cli.add_option("config", &options.config_path, "system config for the server");
  cli.add_option("scales", &scales_text, "map sizes to run, as copies of MAP_DIR");
  cli.add_option("scratch", &scratch, "where tiled maps are written");
  cli.add_option("robots", &options.robots, "concurrent robots");
  cli.add_option("rate-hz", &options.rate_hz, "requests per robot per second");
  cli.add_option("duration-s", &options.duration_s, "length of each run");
  cli.add_option("repeats", &repeats, "runs of each map size, one after another");
  cli.add_option("lcm-url", &options.url,
                 "LCM URL of the run (its own port; robots reply groups next)");
  cli.add_flag("shared-group", &shared_group,
               "replies on the request bus, not on a port per robot (transport.reply_ports 0)");
  cli.add_flag("echo-baseline", &echo_baseline,
               "before each run, the same robots against a stand-in that answers at once with "
               "a small message: the machine's floor");
  cli.add_option("map-reports", &map_reports,
                 "comma list of `liloc_map build --json` reports (lidar=file) for map_ate_m");
  cli.add_option("json", &json_path, "result file ('' for none)");
  return run_program(cli, "bench_mapserver", argc, argv, [&]() -> int {
    options.reply_groups = !shared_group;
    std::vector<Run> runs;
    for (const std::string& scale_text : split_list(scales_text)) {
      const int copies = std::stoi(scale_text);
      std::string map_dir = args[0];
      if (copies > 1) {
        map_dir = scratch + "/x" + std::to_string(copies);
        fs::remove_all(map_dir);
        fs::create_directories(map_dir);
        spdlog::info("writing the map tiled {}x to {}", copies, map_dir);
        in_child_process([&] { write_tiled_map(args[0], map_dir, copies); });
      }
      in_child_process([&] { prepare_reply_clouds(map_dir, options.config_path); });
      for (int repeat = 0; repeat < repeats; ++repeat) {
        for (const bool echo : {true, false}) {
          if (echo && !echo_baseline) {
            continue;
          }
          runs.push_back(run_once(options, map_dir, copies, echo));
          const Run& r = runs.back();
          spdlog::info("{}x{}: {} requests/s, p99 {:.2f} ms, lost {}, steal {:.1f} %", copies,
                       echo ? " echo" : "", r.requests_per_s, r.all.p99_ms, r.lost,
                       r.steal_percent);
        }
      }
    }

    std::printf(
        "| map | answered by | robots | requests/s | reply ms p50 | p99 | max | position p99 | "
        "clouds p99 | server worst position / clouds | lost | MB/s | server RSS MB | steal %% "
        "|\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (const Run& r : runs) {
      // The echo stand-in has no status and no memory of its own worth reporting.
      char worst[64] = "-";
      char rss[32] = "-";
      if (!r.echo) {
        std::snprintf(worst, sizeof(worst), "%.2f / %.2f", r.server_worst_position_ms,
                      r.server_worst_cloud_ms);
        std::snprintf(rss, sizeof(rss), "%.0f", r.server.rss_mb);
      }
      std::printf(
          "| %dx (%zu keyframes, %zu submaps) | %s | %d | %.1f | %.2f | %.2f | %.2f | %.2f | "
          "%.2f | %s | %lld | %.1f | %s | %.1f |\n",
          r.map_copies, r.keyframes, r.submaps, r.echo ? "echo" : "liloc_map_server", r.robots,
          r.requests_per_s, r.all.median_ms, r.all.p99_ms, r.all.max_ms, r.position.p99_ms,
          r.clouds.p99_ms, worst, static_cast<long long>(r.lost), r.mb_per_s, rss, r.steal_percent);
    }
    if (json_path.empty()) {
      return 0;
    }
    eval::JsonWriter json;
    json.begin_object().key("benchmark").string("mapserver").key("maps").begin_array();
    for (const std::string& item : split_list(map_reports)) {
      const size_t eq = item.find('=');
      if (eq == std::string::npos) {
        throw std::invalid_argument("--map-reports: expected lidar=file, got '" + item + "'");
      }
      std::ifstream in(item.substr(eq + 1));
      std::stringstream text;
      text << in.rdbuf();
      const std::string report = text.str();
      const size_t at = report.find("\"map_ate_m\": ");
      if (!in || at == std::string::npos) {
        throw std::invalid_argument("--map-reports: no map_ate_m in " + item.substr(eq + 1));
      }
      json.begin_object()
          .key("lidar")
          .string(item.substr(0, eq))
          .key("map_ate_m")
          .number(std::stod(report.substr(at + 13)))
          .end_object();
    }
    json.end_array().key("runs").begin_array();
    for (const Run& r : runs) {
      json.begin_object()
          .key("answered_by")
          .string(r.echo ? "echo" : "liloc_map_server")
          .key("map_copies")
          .integer(r.map_copies)
          .key("keyframes")
          .integer(static_cast<int64_t>(r.keyframes))
          .key("robots")
          .integer(r.robots)
          .key("reply_groups")
          .boolean(r.reply_groups)
          .key("requests_per_s")
          .number(r.requests_per_s)
          .key("reply_ms_p50")
          .number(r.all.median_ms)
          .key("reply_ms_p99")
          .number(r.all.p99_ms)
          .key("reply_ms_max")
          .number(r.all.max_ms)
          .key("position_reply_ms_p99")
          .number(r.position.p99_ms)
          .key("cloud_reply_ms_p99")
          .number(r.clouds.p99_ms)
          .key("lost_replies")
          .integer(r.lost)
          .key("steal_percent")
          .number(r.steal_percent);
      if (!r.echo) {
        json.key("server_position_reply_ms_max")
            .number(r.server_worst_position_ms)
            .key("server_cloud_reply_ms_max")
            .number(r.server_worst_cloud_ms)
            .key("server_rss_mb")
            .number(r.server.rss_mb)
            .key("server_peak_rss_mb")
            .number(r.server.peak_mb);
      }
      json.end_object();
    }
    json.end_array().end_object();
    storage::write_file_creating_directories(json_path, json.str());
    return 0;
  });
}
