#pragma once
// The one exception of the storage module. Its message names the file (full path) and
// the reason: "missing", "truncated", "checksum mismatch", "path:12: malformed ...", so
// that an operator can tell which file of a map directory is broken and why.

#include <stdexcept>
#include <string>

namespace liloc::storage {

class MapError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;

  static MapError in_file(const std::string& path, const std::string& what) {
    return MapError(path + ": " + what);
  }
  // line_number counts from 1, like editors do.
  static MapError at_line(const std::string& path, int64_t line_number, const std::string& what) {
    return MapError(path + ":" + std::to_string(line_number) + ": " + what);
  }
};

}  // namespace liloc::storage
