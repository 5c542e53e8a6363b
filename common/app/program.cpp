#include "app/program.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <csignal>
#include <iostream>
#include <memory>
#include <stdexcept>

namespace liloc {
namespace {
std::atomic<bool> g_shutdown{false};

// The first signal asks the program to stop at its next check; a second one, for a program
// that does not check or is stuck, ends it as the default action would.
void on_signal(int signal) {
  if (g_shutdown.exchange(true)) {
    std::signal(signal, SIG_DFL);
    std::raise(signal);
  }
}
}  // namespace

void setup_logging(const std::string& level, const std::string& process_name) {
  const spdlog::level::level_enum parsed = spdlog::level::from_str(level);
  // from_str maps anything unknown to "off"; only "off" itself may mean off.
  if (parsed == spdlog::level::off && level != "off") {
    throw std::invalid_argument("unknown log level '" + level +
                                "' (trace, debug, info, warn, error, critical, off)");
  }
  // Logs go to stderr, so that what a program prints (a table, a config, a pose) pipes.
  spdlog::set_default_logger(std::make_shared<spdlog::logger>(
      process_name, std::make_shared<spdlog::sinks::stderr_color_sink_mt>()));
  spdlog::set_level(parsed);
  spdlog::set_pattern("[%H:%M:%S.%e] [" + process_name + "] [%^%l%$] %v");
}

int run_program(CommandLine& cli, const std::string& process_name, int argc,
                const char* const* argv, const std::function<int()>& body) {
  std::string log_level = "info";
  cli.add_option("log-level", &log_level, "trace, debug, info, warn, error, critical or off");
  try {
    if (!cli.parse(argc, argv)) {
      return 0;
    }
    setup_logging(log_level, process_name);
  } catch (const std::invalid_argument& e) {
    std::cerr << process_name << ": " << e.what() << "\n";
    return 2;
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  try {
    return body();
  } catch (const std::exception& e) {
    spdlog::critical("{}", e.what());
    return 1;
  }
}

bool shutdown_requested() { return g_shutdown; }

void request_shutdown() { g_shutdown = true; }

}  // namespace liloc
