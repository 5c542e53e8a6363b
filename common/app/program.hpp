#pragma once
// The frame of every liloc executable: standard options, logging, error reporting and
// shutdown on SIGINT/SIGTERM, so that each process's main() only wires its parts.

#include <functional>
#include <string>

#include "app/command_line.hpp"

namespace liloc {

// Sets up spdlog for a process: level from "trace", "debug", "info", "warn", "error",
// "critical" or "off" (anything else throws std::invalid_argument naming the level),
// and a pattern that names the process.
void setup_logging(const std::string& level, const std::string& process_name);

// Adds --log-level to `cli`, parses argv, sets up logging and runs `body`.
// Returns body's exit code; 0 after --help; 2 for a command-line error; 1 if body
// throws (the error is logged with its message).
int run_program(CommandLine& cli, const std::string& process_name, int argc,
                const char* const* argv, const std::function<int()>& body);

// True once SIGINT or SIGTERM arrived (handlers installed by run_program).
bool shutdown_requested();

// Lets code ask for shutdown as a signal would (tests, end of a replayed log).
void request_shutdown();

}  // namespace liloc
