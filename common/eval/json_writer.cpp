#include "eval/json_writer.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace liloc::eval {

std::string JsonWriter::quote(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\b':
        out += "\\b";
        break;
      case '\f':
        out += "\\f";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char escaped[8];
          std::snprintf(escaped, sizeof(escaped), "\\u%04x", static_cast<unsigned>(c));
          out += escaped;
        } else {
          out += c;  // UTF-8 passes through unchanged
        }
    }
  }
  out += '"';
  return out;
}

void JsonWriter::newline_indent() {
  out_ += '\n';
  out_.append(2 * scopes_.size(), ' ');
}

void JsonWriter::before_value() {
  if (scopes_.empty()) {
    if (root_written_) {
      throw std::logic_error("JsonWriter: a document has one root value");
    }
    root_written_ = true;
    return;
  }
  Scope& scope = scopes_.back();
  if (scope.is_object) {
    if (!key_pending_) {
      throw std::logic_error("JsonWriter: a value inside an object needs a key");
    }
    key_pending_ = false;
    return;  // key() already wrote the separator
  }
  if (!scope.empty) {
    out_ += ',';
  }
  scope.empty = false;
  newline_indent();
}

JsonWriter& JsonWriter::key(const std::string& name) {
  if (scopes_.empty() || !scopes_.back().is_object || key_pending_) {
    throw std::logic_error("JsonWriter: key '" + name + "' outside an object or after a key");
  }
  Scope& scope = scopes_.back();
  if (!scope.empty) {
    out_ += ',';
  }
  scope.empty = false;
  newline_indent();
  out_ += quote(name);
  out_ += ": ";
  key_pending_ = true;
  return *this;
}

JsonWriter& JsonWriter::begin_object() {
  before_value();
  out_ += '{';
  scopes_.push_back({true, true});
  return *this;
}

JsonWriter& JsonWriter::begin_array() {
  before_value();
  out_ += '[';
  scopes_.push_back({false, true});
  return *this;
}

void JsonWriter::close(bool is_object) {
  if (scopes_.empty() || scopes_.back().is_object != is_object || key_pending_) {
    throw std::logic_error(std::string("JsonWriter: unbalanced end_") +
                           (is_object ? "object" : "array"));
  }
  const bool empty = scopes_.back().empty;
  scopes_.pop_back();
  if (!empty) {
    newline_indent();
  }
  out_ += is_object ? '}' : ']';
}

JsonWriter& JsonWriter::end_object() {
  close(true);
  return *this;
}

JsonWriter& JsonWriter::end_array() {
  close(false);
  return *this;
}

JsonWriter& JsonWriter::number(double value) {
  if (!std::isfinite(value)) {
    return null();
  }
  before_value();
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  out_.append(buffer, result.ptr);
  return *this;
}

JsonWriter& JsonWriter::integer(int64_t value) {
  before_value();
  out_ += std::to_string(value);
  return *this;
}

JsonWriter& JsonWriter::string(const std::string& value) {
  before_value();
  out_ += quote(value);
  return *this;
}

JsonWriter& JsonWriter::boolean(bool value) {
  before_value();
  out_ += value ? "true" : "false";
  return *this;
}

JsonWriter& JsonWriter::null() {
  before_value();
  out_ += "null";
  return *this;
}

std::string JsonWriter::str() const {
  if (!scopes_.empty()) {
    throw std::logic_error("JsonWriter: document has an unclosed object or array");
  }
  return out_ + "\n";
}

}  // namespace liloc::eval
