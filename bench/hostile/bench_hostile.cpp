// bench_hostile: the real processes fed the garbage that robots, logs and networks send.
//
// The odometry process reads a session's log into which each case injects its bad input
// (NaN or negative sweep periods, times a month ahead, IMU spikes, sweeps 1 us apart, IMU
// without LiDAR, garbage bytes in the file); per case: its exit status, the ATE of what it
// estimated against the clean run's, the status messages it kept publishing, its peak
// memory and what it refused. The map server is flooded over loopback multicast (partial
// updates, strangers, malformed updates, sequence jumps, bad robot ids); per flood: its
// peak memory, whether MAP.STATUS kept coming, its counters, and whether a good update
// after the floods was still saved.
//
//   bench_hostile SESSION.lcmlog GROUND_TRUTH.tum MAP_DIR [--json bench/results/hostile.json]

#include <spdlog/spdlog.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "app/child_process.hpp"
#include "app/process_memory.hpp"
#include "app/program.hpp"
#include "bridge/lcm_conversions.hpp"
#include "bridge/map_conversions.hpp"
#include "dataset/tum_trajectory.hpp"
#include "eval/json_writer.hpp"
#include "eval/trajectory_metrics.hpp"
#include "liloc/imu_t.hpp"
#include "liloc/lidar_scan_t.hpp"
#include "liloc/odometry_t.hpp"
#include "liloc/status_t.hpp"
#include "transport/channels.hpp"
#include "transport/log_file.hpp"
#include "transport/transport.hpp"

namespace {
using namespace liloc;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr int64_t kMonthUs = 30LL * 86400 * 1000000;

struct Options {
  std::string odometry = "build/bin/liloc_odometry";
  std::string server = "build/bin/liloc_map_server";
  std::string config = "config/liloc.yaml";
  std::string scratch = "/tmp/bench_hostile";
  std::string url = "udpm://239.255.76.67:7731?ttl=0&recv_buf_size=4194304";
  int flood = 20000;  // messages per map-server flood
};

// Runs `child` to its end, sampling its peak memory: (exit status, peak MB).
std::pair<int, double> run_and_watch(ChildProcess& child, double timeout_s) {
  double peak_mb = 0.0;
  const Clock::time_point end = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                   std::chrono::duration<double>(timeout_s));
  while (child.running() && Clock::now() < end) {
    peak_mb = std::max(peak_mb, read_process_memory(std::to_string(child.pid())).peak_mb);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return {child.wait(1.0), peak_mb};
}

// ---------------------------------------------------------------------------------------
// The odometry process on a log with injected input.

struct OdometryCase {
  std::string name;
  std::string injected;  // what and how much
  // Copies the session's events into `out`; may add, change or drop them.
  std::function<void(const transport::LogEventView&, transport::LogWriter&, int64_t index)> copy;
  // Applied to the written file (for damage below the event level).
  std::function<void(const std::string& path)> after;
};

struct OdometryRow {
  std::string name, injected;
  int exit_status = 0;
  double ate_m = -1.0;
  int64_t estimates = 0;
  int64_t statuses = 0;
  double max_status_gap_s = 0.0;  // of the status messages' times, while estimates came
  double peak_rss_mb = 0.0;
  std::map<std::string, int64_t> counters;  // of the last status
};

template <class Msg>
void write_message(transport::LogWriter& out, const std::string& channel, int64_t utime, Msg msg) {
  out.write(channel, utime, msg);
}

OdometryRow run_odometry_case(const Options& options, const OdometryCase& c,
                              const std::string& log_path, const Trajectory& ground_truth) {
  const std::string in = options.scratch + "/" + c.name + ".lcmlog";
  const std::string out = options.scratch + "/" + c.name + "_out.lcmlog";
  {
    transport::LogReader reader(log_path);
    transport::LogWriter writer(in);
    transport::LogEventView event;
    int64_t index = 0;
    while (reader.next(event)) {
      c.copy(event, writer, index++);
    }
    writer.flush();
  }
  if (c.after) {
    c.after(in);
  }
  fs::remove(out);
  ChildProcess odometry(options.odometry,
                        {"--config", options.config, "--lcm-url", "file://" + in + "?speed=0",
                         "--publish-url", "file://" + out + "?mode=w", "--log-level", "error"});
  OdometryRow row;
  row.name = c.name;
  row.injected = c.injected;
  std::tie(row.exit_status, row.peak_rss_mb) = run_and_watch(odometry, 600.0);

  transport::LogReader reader(out);
  transport::LogEventView event;
  std::vector<StampedPose> poses;
  int64_t last_status_utime = 0;
  while (reader.next(event)) {
    if (event.channel == "robot0.ODOM") {
      liloc::odometry_t m;
      if (transport::decode(event, m)) {
        poses.push_back({m.header.utime * 1e-6, bridge::from_msg(m.pose)});
      }
    } else if (event.channel == "robot0.STATUS.odometry") {
      liloc::status_t m;
      if (!transport::decode(event, m)) {
        continue;
      }
      ++row.statuses;
      if (last_status_utime != 0) {
        row.max_status_gap_s =
            std::max(row.max_status_gap_s, (event.utime - last_status_utime) * 1e-6);
      }
      last_status_utime = event.utime;
      row.counters.clear();
      for (int32_t k = 0; k < m.num_counters; ++k) {
        row.counters[m.counter_names[k]] = m.counter_values[k];
      }
    }
  }
  row.estimates = static_cast<int64_t>(poses.size());
  std::sort(poses.begin(), poses.end(),
            [](const StampedPose& a, const StampedPose& b) { return a.time_s < b.time_s; });
  poses.erase(
      std::unique(poses.begin(), poses.end(),
                  [](const StampedPose& a, const StampedPose& b) { return a.time_s == b.time_s; }),
      poses.end());
  if (poses.size() > 10) {
    row.ate_m = eval::evaluate_trajectory(ground_truth, Trajectory(poses), eval::EvalConfig{})
                    .ate_position_rmse_m;
  }
  return row;
}

std::vector<OdometryCase> odometry_cases(int64_t events) {
  const auto copy = [](const transport::LogEventView& e, transport::LogWriter& out) {
    out.write_raw(e.channel, e.utime, e.data, e.size);
  };
  const auto scan_of = [](const transport::LogEventView& e) {
    liloc::lidar_scan_t m;
    transport::decode(e, m);
    return m;
  };
  const auto imu_of = [](const transport::LogEventView& e) {
    liloc::imu_t m;
    transport::decode(e, m);
    return m;
  };
  const int64_t middle = events / 2;
  std::vector<OdometryCase> cases;
  cases.push_back(
      {"clean", "-", [=](const auto& e, auto& out, int64_t) { copy(e, out); }, nullptr});
  for (const auto& [name, period] :
       {std::pair<std::string, float>{"nan_period", std::numeric_limits<float>::quiet_NaN()},
        {"negative_period", -0.1f}}) {
    const float bad = period;
    cases.push_back({name, "a copy of every 20th sweep with period " + std::to_string(bad),
                     [=, sweeps = std::make_shared<int>(0)](const auto& e, auto& out, int64_t) {
                       copy(e, out);
                       if (e.channel == "robot0.LIDAR" && ++*sweeps % 20 == 0) {
                         liloc::lidar_scan_t m = scan_of(e);
                         m.scan_period_s = bad;
                         write_message(out, e.channel, e.utime, m);
                       }
                     },
                     nullptr});
  }
  cases.push_back({"future_sweep_and_imu", "one sweep and one IMU sample a month ahead",
                   [=](const auto& e, auto& out, int64_t i) {
                     copy(e, out);
                     if (i == middle) {
                       liloc::imu_t imu;
                       imu.header = bridge::make_header(e.utime + kMonthUs, "robot0", "body");
                       imu.num_samples = 1;
                       imu.samples.push_back(
                           bridge::to_msg(ImuSample{e.utime + kMonthUs, {0, 0, 9.81}, {0, 0, 0}}));
                       write_message(out, "robot0.IMU", e.utime, imu);
                       LidarScan scan;
                       scan.utime_us = e.utime + kMonthUs;
                       scan.points.push_back({Eigen::Vector3f(5, 0, 0), 1, 0, 0});
                       write_message(out, "robot0.LIDAR", e.utime,
                                     bridge::to_msg(scan, "robot0", "lidar", "vlp16"));
                     }
                   },
                   nullptr});
  cases.push_back({"imu_spikes", "1 IMU sample in 4000 at 10^6 m/s^2",
                   [=, samples = std::make_shared<int>(0)](const auto& e, auto& out, int64_t) {
                     if (e.channel == "robot0.IMU" && ++*samples % 4000 == 0) {
                       liloc::imu_t m = imu_of(e);
                       for (liloc::imu_sample_t& s : m.samples) {
                         s.linear_acceleration[0] = 1e6;
                       }
                       write_message(out, e.channel, e.utime, m);
                     } else {
                       copy(e, out);
                     }
                   },
                   nullptr});
  cases.push_back({"sweeps_1us_apart", "3000 sweeps of period 0, 1 us apart, mid-log",
                   [=](const auto& e, auto& out, int64_t i) {
                     copy(e, out);
                     if (i == middle) {
                       for (int k = 0; k < 3000; ++k) {
                         LidarScan scan;
                         scan.utime_us = e.utime + k;
                         scan.scan_period_s = 0.0f;
                         scan.points.push_back({Eigen::Vector3f(5, 0, 0), 1, 0, 0});
                         write_message(out, "robot0.LIDAR", e.utime,
                                       bridge::to_msg(scan, "robot0", "lidar", "vlp16"));
                       }
                     }
                   },
                   nullptr});
  cases.push_back({"imu_without_lidar", "no sweep after the middle of the log",
                   [=](const auto& e, auto& out, int64_t i) {
                     if (i < middle || e.channel != "robot0.LIDAR") {
                       copy(e, out);
                     }
                   },
                   nullptr});
  cases.push_back({"garbage_in_log", "4 KiB of random bytes in the middle of the file",
                   [=](const auto& e, auto& out, int64_t) { copy(e, out); },
                   [](const std::string& path) {
                     std::ifstream in(path, std::ios::binary);
                     std::string bytes((std::istreambuf_iterator<char>(in)),
                                       std::istreambuf_iterator<char>());
                     std::mt19937 rng(7);
                     std::string garbage(4096, '\0');
                     for (char& c : garbage) {
                       c = static_cast<char>(rng() & 0xff);
                     }
                     bytes.insert(bytes.size() / 2, garbage);
                     std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
                   }});
  return cases;
}

// ---------------------------------------------------------------------------------------
// The map server flooded over loopback.

struct ServerRow {
  std::string flood;
  int64_t sent = 0;
  double peak_rss_mb = 0.0;
  int64_t statuses = 0;           // MAP.STATUS received during the flood and a second after
  double max_status_gap_s = 0.0;  // between them
  std::string counters;           // what the flood added to the counters it should move
};

class StatusWatcher {
 public:
  explicit StatusWatcher(const std::string& url)
      : bus_([&] {
          transport::TransportConfig c;
          c.url = url;
          return c;
        }()) {
    bus_.subscribe<liloc::status_t>(
        "MAP.STATUS", [this](const liloc::status_t& m, const transport::ReceiveInfo&) {
          const Clock::time_point now = Clock::now();
          if (statuses_ > 0) {
            max_gap_s_ =
                std::max(max_gap_s_.load(), std::chrono::duration<double>(now - last_).count());
          }
          last_ = now;
          ++statuses_;
          std::lock_guard<std::mutex> lock(mutex_);
          for (int32_t k = 0; k < m.num_counters; ++k) {
            counters_[m.counter_names[k]] = m.counter_values[k];
          }
        });
    thread_ = std::thread([this] {
      while (!stop_) {
        bus_.handle(50);
      }
    });
  }
  ~StatusWatcher() {
    stop_ = true;
    thread_.join();
  }
  // Forgets what it saw (a new flood starts).
  void reset() {
    statuses_ = 0;
    max_gap_s_ = 0.0;
  }
  int64_t statuses() const { return statuses_; }
  double max_gap_s() const { return max_gap_s_; }
  int64_t counter(const std::string& name) const {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = counters_.find(name);
    return it == counters_.end() ? 0 : it->second;
  }

 private:
  transport::Transport bus_;
  std::atomic<bool> stop_{false};
  std::atomic<int64_t> statuses_{0};
  std::atomic<double> max_gap_s_{0.0};
  Clock::time_point last_;
  mutable std::mutex mutex_;  // guards counters_
  std::map<std::string, int64_t> counters_;
  std::thread thread_;
};

MapUpdatePart update_part(const std::string& robot, const std::string& session, int64_t id,
                          int chunks, int keyframes, int points) {
  MapUpdatePart part;
  part.robot_id = robot;
  part.session_id = session;
  part.update_id = id;
  part.num_chunks = chunks;
  for (int k = 0; k < keyframes; ++k) {
    UpdateKeyframe kf;
    kf.sender_keyframe_id = k;
    kf.utime_us = 1'750'000'000'000'000 + k * 100000;
    kf.T_map_body.translation() = Eigen::Vector3d(500.0, 500.0 + k, 0.0);
    kf.fitness_m = 0.05;
    for (int p = 0; p < points; ++p) {
      kf.cloud_body.push_back(Eigen::Vector3f(0.1f * p, 0.0f, -1.0f), 1.0f);
    }
    part.keyframes.push_back(kf);
  }
  return part;
}

std::vector<ServerRow> run_server_floods(const Options& options, const std::string& map_dir) {
  const std::string copy = options.scratch + "/map";
  fs::remove_all(copy);
  fs::copy(map_dir, copy, fs::copy_options::recursive);
  ChildProcess server(options.server, {"--config", options.config, "--map", copy, "--lcm-url",
                                       options.url, "--log-level", "error"});
  StatusWatcher status(options.url);
  transport::TransportConfig config;
  config.url = options.url;
  transport::Transport bus(config);
  for (int i = 0; i < 100 && status.statuses() == 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  if (status.statuses() == 0) {
    throw std::runtime_error("liloc_map_server sent no MAP.STATUS within 10 s");
  }
  const int64_t version_before = status.counter("map_version");
  const auto send_update = [&](const MapUpdatePart& part) {
    liloc::map_update_t msg = bridge::to_msg(part, 0);
    bus.publish("MAP.UPDATE", msg);
  };
  std::vector<ServerRow> rows;
  const auto flood = [&](const std::string& name, const std::vector<std::string>& counters,
                         const std::function<void(int)>& send) {
    status.reset();
    ServerRow row;
    row.flood = name;
    std::vector<int64_t> before;
    for (const std::string& c : counters) {
      before.push_back(status.counter(c));
    }
    for (int i = 0; i < options.flood; ++i) {
      send(i);
      ++row.sent;
      if (i % 200 == 0) {  // a pace the loopback carries: floods test the server, not UDP
        row.peak_rss_mb =
            std::max(row.peak_rss_mb, read_process_memory(std::to_string(server.pid())).peak_mb);
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));
    row.peak_rss_mb =
        std::max(row.peak_rss_mb, read_process_memory(std::to_string(server.pid())).peak_mb);
    row.statuses = status.statuses();
    row.max_status_gap_s = status.max_gap_s();
    for (size_t k = 0; k < counters.size(); ++k) {
      row.counters += (row.counters.empty() ? "" : ", ") + counters[k] + " +" +
                      std::to_string(status.counter(counters[k]) - before[k]);
    }
    rows.push_back(row);
    spdlog::info("flood {}: peak {:.0f} MB, {} statuses", name, row.peak_rss_mb, row.statuses);
  };
  flood("partial updates (chunk 0 of 2, 200 points each)",
        {"updates_refused_busy", "updates_pending"},
        [&](int i) { send_update(update_part("robot0", "flood", 1000 + i, 2, 1, 200)); });
  flood("updates from unknown robot ids", {"updates_refused_robot", "MAP.UPDATE.senders_forgotten"},
        [&](int i) { send_update(update_part("stranger" + std::to_string(i), "x", 1, 1, 1, 10)); });
  flood("malformed updates (NaN fitness, 1e308 pose, ',' or control character in the session)",
        {"updates_rejected"}, [&](int i) {
          MapUpdatePart part = update_part("robot1", "s", 5000 + i, 1, 2, 10);
          switch (i % 4) {
            case 0:
              part.keyframes[0].fitness_m = std::numeric_limits<double>::quiet_NaN();
              break;
            case 1:
              part.keyframes[1].T_map_body.translation().x() = 1e308;
              break;
            case 2:
              part.session_id = "a,b";
              break;
            default:
              part.session_id = "\x01";
          }
          send_update(part);
        });
  flood("requests with bad robot ids and 64+ distinct reply_url values",
        {"requests_refused", "requests"}, [&](int i) {
          SubmapQuery q;
          q.robot_id = i % 2 == 0 ? std::string("bad\nrobot") : "robot2";
          q.position = Eigen::Vector3d(0, 0, 0);
          q.include_clouds = false;
          q.reply_url = "udpm://239.255.76.67:" + std::to_string(8000 + i % 512) + "?ttl=1";
          liloc::submap_request_t msg = bridge::to_msg(q, 0);
          bus.publish("MAP.REQUEST", msg);
        });
  flood("sequence numbers jumping by 2^62", {"MAP.REQUEST.sequence_resets", "MAP.REQUEST.dropped"},
        [&](int i) {
          SubmapQuery q;
          q.robot_id = "robot3";
          q.include_clouds = false;
          liloc::submap_request_t msg = bridge::to_msg(q, 0);
          msg.header.seq = (i % 2 == 0) ? (int64_t{1} << 62) : i;
          std::vector<uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
          msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
          bus.publish_raw("MAP.REQUEST", bytes.data(), bytes.size());
        });
  // After all that, a good update is merged and saved.
  status.reset();
  send_update(update_part("robot0", "good", 1, 1, 25, 500));
  ServerRow saved;
  saved.flood = "a good update after the floods";
  saved.sent = 1;
  for (int i = 0; i < 100 && status.counter("map_version") == version_before; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  saved.statuses = status.statuses();
  saved.counters = "map_version " + std::to_string(version_before) + " -> " +
                   std::to_string(status.counter("map_version")) + ", updates_merged " +
                   std::to_string(status.counter("updates_merged"));
  saved.peak_rss_mb = read_process_memory(std::to_string(server.pid())).peak_mb;
  const int exit_status = server.stop(SIGINT, 60.0);
  saved.counters += ", exit status " + std::to_string(exit_status);
  rows.push_back(saved);
  return rows;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args;
  Options options;
  std::string json_path = "bench/results/hostile.json";
  CommandLine cli("bench_hostile",
                  "The odometry process and the map server fed hostile input: exit status, "
                  "accuracy on the good stream, status, memory, counters.");
  cli.add_positional("SESSION_LOG GROUND_TRUTH MAP_DIR", &args,
                     "a session's log and ground truth (odometry), a map directory (server)", 3);
  cli.add_option("odometry", &options.odometry, "liloc_odometry binary");
  cli.add_option("server", &options.server, "liloc_map_server binary");
  cli.add_option("config", &options.config, "system config");
  cli.add_option("scratch", &options.scratch, "where the modified logs and the map copy go");
  cli.add_option("lcm-url", &options.url, "the bus of the map-server floods (a private port)");
  cli.add_option("flood", &options.flood, "messages per map-server flood");
  cli.add_option("json", &json_path, "result file ('' for none)");
  return run_program(cli, "bench_hostile", argc, argv, [&]() -> int {
    fs::create_directories(options.scratch);
    const Trajectory ground_truth = read_tum(args[1]);
    int64_t events = 0;
    {
      transport::LogReader reader(args[0]);
      transport::LogEventView event;
      while (reader.next(event)) {
        ++events;
      }
    }
    std::vector<OdometryRow> odometry;
    for (const OdometryCase& c : odometry_cases(events)) {
      odometry.push_back(run_odometry_case(options, c, args[0], ground_truth));
      spdlog::info("odometry case {}: exit {}, ATE {:.3f} m", c.name, odometry.back().exit_status,
                   odometry.back().ate_m);
    }
    std::printf(
        "| odometry case | injected | exit | estimates | ATE (m) | statuses | max status gap (s) | "
        "peak RSS (MB) | refused / bounded |\n|---|---|---|---|---|---|---|---|---|\n");
    for (const OdometryRow& r : odometry) {
      std::string refused;
      for (const auto& [name, value] : r.counters) {
        if (value > 0 && (name.rfind("rejected_", 0) == 0 || name == "scans_dropped_queue" ||
                          name == "imu_dropped_old" || name == "scans_failed" ||
                          name == "restarts" || name.rfind("log.", 0) == 0)) {
          refused += (refused.empty() ? "" : ", ") + name + " " + std::to_string(value);
        }
      }
      std::printf("| %s | %s | %d | %lld | %.3f | %lld | %.1f | %.0f | %s |\n", r.name.c_str(),
                  r.injected.c_str(), r.exit_status, static_cast<long long>(r.estimates), r.ate_m,
                  static_cast<long long>(r.statuses), r.max_status_gap_s, r.peak_rss_mb,
                  refused.empty() ? "-" : refused.c_str());
    }
    const std::vector<ServerRow> server = run_server_floods(options, args[2]);
    std::printf(
        "\n| map-server flood | sent | peak RSS (MB) | MAP.STATUS during | max gap (s) | "
        "counters |\n|---|---|---|---|---|---|\n");
    for (const ServerRow& r : server) {
      std::printf("| %s | %lld | %.0f | %lld | %.1f | %s |\n", r.flood.c_str(),
                  static_cast<long long>(r.sent), r.peak_rss_mb, static_cast<long long>(r.statuses),
                  r.max_status_gap_s, r.counters.c_str());
    }
    if (!json_path.empty()) {
      eval::JsonWriter json;
      json.begin_object().key("benchmark").string("hostile").key("odometry").begin_array();
      for (const OdometryRow& r : odometry) {
        json.begin_object()
            .key("case")
            .string(r.name)
            .key("exit_status")
            .integer(r.exit_status)
            .key("estimates")
            .integer(r.estimates)
            .key("ate_m")
            .number(r.ate_m)
            .key("statuses")
            .integer(r.statuses)
            .key("max_status_gap_s")
            .number(r.max_status_gap_s)
            .key("peak_rss_mb")
            .number(r.peak_rss_mb)
            .end_object();
      }
      json.end_array().key("map_server").begin_array();
      for (const ServerRow& r : server) {
        json.begin_object()
            .key("flood")
            .string(r.flood)
            .key("sent")
            .integer(r.sent)
            .key("peak_rss_mb")
            .number(r.peak_rss_mb)
            .key("statuses")
            .integer(r.statuses)
            .key("max_status_gap_s")
            .number(r.max_status_gap_s)
            .key("counters")
            .string(r.counters)
            .end_object();
      }
      json.end_array().end_object();
      std::ofstream(json_path) << json.str() << "\n";
    }
    return 0;
  });
}
