#include "dataset/text_line_reader.hpp"

#include <cstdlib>
#include <sstream>

#include "dataset/dataset_error.hpp"

namespace liloc::dataset {

TextLineReader::TextLineReader(const std::string& path) : path_(path), in_(path) {
  if (!in_) {
    throw DatasetError::in_file(path, "cannot open");
  }
}

bool TextLineReader::next(std::string& line) {
  while (std::getline(in_, line)) {
    ++line_number_;
    if (!line.empty() && line.back() == '\r') {
      line.pop_back();
    }
    if (line.find_first_not_of(" \t") != std::string::npos) {
      return true;
    }
  }
  return false;
}

std::vector<double> TextLineReader::numbers(const std::string& line, char separator,
                                            size_t expected_fields) const {
  std::vector<std::string> tokens;
  if (separator == ' ') {
    std::istringstream fields(line);
    for (std::string token; fields >> token;) {
      tokens.push_back(token);
    }
  } else {
    std::istringstream fields(line);
    for (std::string token; std::getline(fields, token, separator);) {
      tokens.push_back(token);
    }
    if (!line.empty() && line.back() == separator) {
      tokens.emplace_back();  // "1,2," has an empty third field
    }
  }
  if (expected_fields > 0 && tokens.size() != expected_fields) {
    fail("expected " + std::to_string(expected_fields) + " fields, found " +
         std::to_string(tokens.size()));
  }
  std::vector<double> values;
  values.reserve(tokens.size());
  for (std::string& token : tokens) {
    const size_t first = token.find_first_not_of(" \t");
    const size_t last = token.find_last_not_of(" \t");
    token = first == std::string::npos ? "" : token.substr(first, last - first + 1);
    char* end = nullptr;
    const double value = std::strtod(token.c_str(), &end);
    if (token.empty() || *end != '\0') {
      fail("field " + std::to_string(values.size() + 1) + " '" + token + "' is not a number");
    }
    values.push_back(value);
  }
  return values;
}

void TextLineReader::fail(const std::string& what) const {
  throw DatasetError::at_line(path_, line_number_, what);
}

}  // namespace liloc::dataset
