// liloc_log: inspect, play, record LCM logs, and write a sample of every liloc type.
//
//   liloc_log info LOG                    channels, types, rates, decode errors, gaps
//   liloc_log play LOG [--speed S]        publish a log (0 = as fast as possible)
//   liloc_log record LOG [--duration-s T] record the bus, like lcm-logger
//   liloc_log sample LOG                  one message of every type (checks lcm-spy)
//
// Each command exits 1 if data was lost: info and play on a damaged log (corrupt regions,
// a truncated end), play on messages the bus refused, record on messages it could not
// decode, take or write, sample on a failed write.

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
  const tools::LogSummary summary = tools::summarize_log(path);
  std::cout << tools::format_summary(summary);
  return summary.damage.any() ? 1 : 0;
}

// The exit code of a command that moves messages: 1, after saying why, if any were lost.
int exit_code(const std::string& source, const transport::LogDamage* damage,
              int64_t messages_lost) {
  bool lost = false;
  if (damage != nullptr && damage->any()) {
    spdlog::error("{}: damaged log: {}", source, damage->summary());
    lost = true;
  }
  if (messages_lost > 0) {
    spdlog::error("{} messages lost (see the errors above)", messages_lost);
    lost = true;
  }
  return lost ? 1 : 0;
}

// What a recorder's subscriptions could not take: too large, undecodable, or not written.
int64_t messages_not_recorded(const transport::Transport& bus) {
  int64_t lost = 0;
  for (const auto& [channel, s] : bus.stats()) {
    lost += s.oversized + s.decode_errors + s.handler_errors;
  }
  return lost;
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
  writer.flush();
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
      const transport::ReplayResult result =
          transport::replay_log(path, bus, {speed}, [] { return !shutdown_requested(); });
      spdlog::info("published {} messages from {}", result.published, path);
      return exit_code(path, &result.damage, bus.publish_errors());
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
    writer.flush();
    spdlog::info("recorded {} messages to {}", writer.events_written(), path);
    return exit_code(url, bus.log_damage(), messages_not_recorded(bus));
  });
}
