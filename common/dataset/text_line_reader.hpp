#pragma once
// Reads a text data file (CSV, times.txt, poses) one line at a time, keeping the line
// number so that every parse error names "path:line". Streams: large CSV files (NCLT's
// IMU and ground truth) are never loaded whole.

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

namespace liloc::dataset {

class TextLineReader {
 public:
  // Throws DatasetError naming the path if the file cannot be opened.
  explicit TextLineReader(const std::string& path);

  // Next line that is neither empty nor whitespace only (trailing '\r' removed);
  // false at the end of the file.
  bool next(std::string& line);

  // Splits `line` at `separator` (' ' splits at runs of spaces and tabs) and parses each
  // field as a number; "nan" and "inf" parse (callers decide what non-finite means).
  // Throws DatasetError at the current line if a field is not a number or, when
  // expected_fields > 0, if the field count differs.
  std::vector<double> numbers(const std::string& line, char separator,
                              size_t expected_fields) const;

  [[noreturn]] void fail(const std::string& what) const;

  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::ifstream in_;
  int64_t line_number_ = 0;
};

}  // namespace liloc::dataset
