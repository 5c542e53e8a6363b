#include "app/process_memory.hpp"

#include <fstream>

namespace liloc {

ProcessMemory read_process_memory(const std::string& pid) {
  std::ifstream status("/proc/" + pid + "/status");
  ProcessMemory memory;
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmRSS:", 0) == 0) {
      memory.rss_mb = std::stod(line.substr(6)) / 1024.0;
    } else if (line.rfind("VmHWM:", 0) == 0) {
      memory.peak_mb = std::stod(line.substr(6)) / 1024.0;
    }
  }
  return memory;
}

}  // namespace liloc
