#pragma once
// The one exception of the dataset readers. Its message always names the file, and where
// the problem is: the line of a text file ("path:12: ...") or the byte offset of a binary
// file ("path: byte 4096: ..."), so that a bad download can be found and fixed.

#include <cstdint>
#include <stdexcept>
#include <string>

namespace liloc::dataset {

class DatasetError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;

  static DatasetError in_file(const std::string& path, const std::string& what) {
    return DatasetError(path + ": " + what);
  }
  // line_number counts from 1, like editors do.
  static DatasetError at_line(const std::string& path, int64_t line_number,
                              const std::string& what) {
    return DatasetError(path + ":" + std::to_string(line_number) + ": " + what);
  }
  static DatasetError at_byte(const std::string& path, uint64_t byte_offset,
                              const std::string& what) {
    return DatasetError(path + ": byte " + std::to_string(byte_offset) + ": " + what);
  }
};

}  // namespace liloc::dataset
