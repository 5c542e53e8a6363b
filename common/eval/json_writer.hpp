#pragma once
// A small streaming JSON writer for result files (liloc_eval, bench/results/*.json):
// two-space indentation, correct string escaping, and non-finite numbers written as
// null, because JSON has no NaN and a missing metric must not look like a number.

#include <cstdint>
#include <string>
#include <vector>

namespace liloc::eval {

class JsonWriter {
 public:
  JsonWriter& begin_object();
  JsonWriter& end_object();
  JsonWriter& begin_array();
  JsonWriter& end_array();

  // Inside an object, every value is preceded by its key.
  JsonWriter& key(const std::string& name);

  // Shortest decimal form that reads back to the same double; NaN and +-inf as null.
  JsonWriter& number(double value);
  JsonWriter& integer(int64_t value);
  JsonWriter& string(const std::string& value);
  JsonWriter& boolean(bool value);
  JsonWriter& null();

  // The document; throws std::logic_error if an object or array is still open.
  std::string str() const;

  // `text` as a quoted JSON string literal.
  static std::string quote(const std::string& text);

 private:
  struct Scope {
    bool is_object = false;
    bool empty = true;
  };
  // Writes the separator and indentation that come before a value or key; throws
  // std::logic_error on misuse (a value in an object without a key, two roots ...).
  void before_value();
  void close(bool is_object);
  void newline_indent();

  std::string out_;
  std::vector<Scope> scopes_;
  bool key_pending_ = false;
  bool root_written_ = false;
};

}  // namespace liloc::eval
