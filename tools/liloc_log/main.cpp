// liloc_log: inspect, play, record LCM logs, and write a sample of every liloc type.
//
//   liloc_log info LOG                    channels, types, rates, decode errors, gaps
//   liloc_log play LOG [--speed S]        publish a log (0 = as fast as possible)
//   liloc_log record LOG [--duration-s T] record the bus, like lcm-logger
//   liloc_log sample LOG                  one message of every type (checks lcm-spy)

#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include "app/program.hpp"
#include "bridge/message_samples.hpp"
#include "liloc_log/log_inspector.hpp"
#include "transport/log_file.hpp"

namespace {
using namespace liloc;

const char* kUsage =
    "usage: liloc_log <info|play|record|sample> LOG [options]   (liloc_log <command> --help)\n";

int info(const std::string& path) {
  std::cout << tools::format_summary(tools::summarize_log(path));
  return 0;
}

// Writes ten numbered samples of Msg (only messages with a header carry a number).
template <class Msg>
void write_samples(transport::LogWriter& writer, const std::string& robot_id, int64_t& utime) {
  const std::string channel = robot_id + ".SAMPLE." + Msg::getTypeName();
  for (int i = 0; i < 10; ++i) {
    Msg msg = bridge::make_sample<Msg>(robot_id);
    if constexpr (bridge::HasHeader<Msg>::value) {
      msg.header.seq = i;
    }
    writer.write(channel, utime, msg);
    utime += 10000;
  }
}

int sample(const std::string& path, const std::string& robot_id) {
  transport::LogWriter writer(path);
  int64_t utime = bridge::make_sample<liloc::header_t>(robot_id).utime;
#define LILOC_WRITE_SAMPLE(type) write_samples<liloc::type>(writer, robot_id, utime);
  LILOC_FOR_EACH_LCM_TYPE(LILOC_WRITE_SAMPLE)
#undef LILOC_WRITE_SAMPLE
  spdlog::info("wrote {} messages to {}", writer.events_written(), path);
  return 0;
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << kUsage;
    return 2;
  }
  const std::string command = argv[1];
  std::vector<std::string> files;
  double speed = 1.0;
  double duration_s = 0.0;
  std::string url = transport::TransportConfig{}.url;
  std::string channels = ".*";
  std::string robot_id = "robot0";
  CommandLine cli("liloc_log " + command, "LCM log tool (" + command + ")");
  cli.add_positional("LOG", &files, "the LCM log file", 1);
  if (command == "play") {
    cli.add_option("speed", &speed, "playback speed factor; 0 = as fast as possible");
    cli.add_option("lcm-url", &url, "LCM provider to publish on");
  } else if (command == "record") {
    cli.add_option("duration-s", &duration_s, "stop after this long; 0 = until Ctrl-C");
    cli.add_option("lcm-url", &url, "LCM provider to record from");
    cli.add_option("channels", &channels, "regex of the channels to record");
  } else if (command == "sample") {
    cli.add_option("robot", &robot_id, "robot id of the sample messages");
  } else if (command != "info") {
    std::cerr << "liloc_log: unknown command '" << command << "'\n" << kUsage;
    return 2;
  }
  return run_program(cli, "liloc_log", argc - 1, argv + 1, [&]() -> int {
    const std::string& path = files.front();
    if (command == "info") {
      return info(path);
    }
    if (command == "sample") {
      return sample(path, robot_id);
    }
    transport::TransportConfig config;
    config.url = url;
    transport::Transport bus(config);
    if (command == "play") {
      const int64_t n =
          transport::replay_log(path, bus, {speed}, [] { return !shutdown_requested(); });
      spdlog::info("published {} messages from {}", n, path);
      return 0;
    }
    transport::LogWriter writer(path);
    writer.record(bus, channels);
    const auto start = std::chrono::steady_clock::now();
    while (!shutdown_requested()) {
      if (duration_s > 0 &&
          std::chrono::steady_clock::now() - start > std::chrono::duration<double>(duration_s)) {
        break;
      }
      if (bus.handle(100) < 0) {
        break;
      }
    }
    spdlog::info("recorded {} messages to {}", writer.events_written(), path);
    return 0;
  });
}
