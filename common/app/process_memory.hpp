#pragma once
// Resident memory of a process, from /proc (Linux), for benchmarks and status.

#include <string>

namespace liloc {

struct ProcessMemory {
  double rss_mb = 0.0;   // resident now
  double peak_mb = 0.0;  // high-water mark of the resident set
};

// pid "self" or a number. Zeros if the process is gone.
ProcessMemory read_process_memory(const std::string& pid = "self");

}  // namespace liloc
