#pragma once
// Loads YAML into <Module>Config structs. A config struct keeps its defaults (the paper's
// values) in member initializers and lists its fields once, in a visit_fields() template:
//
//   struct OdometryConfig {
//     double keyframe_translation_m = 1.0;
//     template <class Visitor> void visit_fields(Visitor& v) {
//       v("keyframe_translation_m", keyframe_translation_m);
//     }
//     void validate() const;  // optional: throw std::invalid_argument on a bad value
//   };
//
// A key missing from the file keeps its default. An unknown (for example misspelled) or
// repeated key, a value of the wrong type, a number that is not finite, or a value that
// validate() refuses is a ConfigError naming the file, the line and the full key.

#include <spdlog/spdlog.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <array>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace liloc {

class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

namespace config_detail {

template <class T, class = void>
struct IsVisitable : std::false_type {};
template <class T>
struct IsVisitable<T, std::void_t<decltype(std::declval<T&>().visit_fields(std::declval<int&>()))>>
    : std::true_type {};

template <class T, class = void>
struct HasValidate : std::false_type {};
template <class T>
struct HasValidate<T, std::void_t<decltype(std::declval<const T&>().validate())>> : std::true_type {
};

template <class T>
struct IsVector : std::false_type {};
template <class T, class A>
struct IsVector<std::vector<T, A>> : std::true_type {};

template <class T>
struct IsStdArray : std::false_type {};
template <class T, size_t N>
struct IsStdArray<std::array<T, N>> : std::true_type {};

template <class T>
struct IsEigenFixed : std::false_type {};
template <class S, int R, int C, int O, int MR, int MC>
struct IsEigenFixed<Eigen::Matrix<S, R, C, O, MR, MC>> : std::bool_constant<(R > 0 && C > 0)> {};

template <class T>
const char* type_name() {
  if constexpr (std::is_same_v<T, bool>) {
    return "true or false";
  } else if constexpr (std::is_integral_v<T>) {
    return "an integer";
  } else if constexpr (std::is_floating_point_v<T>) {
    return "a number";
  } else {
    return "a string";
  }
}

std::string location(const std::string& file, const YAML::Node& node);

}  // namespace config_detail

// Visitor that reads the fields of a config struct from one YAML map.
class YamlReader {
 public:
  YamlReader(YAML::Node node, std::string file, std::string key_path)
      : node_(std::move(node)), file_(std::move(file)), key_path_(std::move(key_path)) {}

  template <class T>
  void operator()(const char* key, T& value) {
    visited_.insert(key);
    const YAML::Node child = node_[key];
    if (child) {
      read(child, join(key), value);
    }
  }

  // A key the struct knows but does not read (a section another process uses): it is
  // not an unknown key, and its contents are that process's to check.
  void allow(const char* key) { visited_.insert(key); }

  // Throws for keys in the map that the struct did not visit, and for keys given twice
  // (YAML keeps both, and the first would silently win).
  void reject_unknown_keys() const {
    std::set<std::string> seen;
    for (const auto& entry : node_) {
      const std::string key = entry.first.as<std::string>();
      if (!seen.insert(key).second) {
        throw ConfigError(config_detail::location(file_, entry.first) + ": key '" + join(key) +
                          "' is given twice");
      }
      if (visited_.count(key) == 0) {
        throw ConfigError(config_detail::location(file_, entry.first) + ": unknown key '" +
                          join(key) + "'" + known_keys());
      }
    }
  }

  template <class T>
  void read(const YAML::Node& node, const std::string& key, T& value) const {
    using namespace config_detail;
    if constexpr (IsVisitable<T>::value) {
      if (!node.IsMap()) {
        fail(node, key, "must be a map of keys");
      }
      YamlReader nested(node, file_, key);
      value.visit_fields(nested);
      nested.reject_unknown_keys();
      if constexpr (HasValidate<T>::value) {
        try {
          value.validate();
        } catch (const std::invalid_argument& e) {
          fail(node, key, e.what());
        }
      }
    } else if constexpr (IsVector<T>::value) {
      if (!node.IsSequence()) {
        fail(node, key, "must be a list");
      }
      value.clear();
      value.resize(node.size());
      for (size_t i = 0; i < node.size(); ++i) {
        read(node[i], key + "[" + std::to_string(i) + "]", value[i]);
      }
    } else if constexpr (IsStdArray<T>::value || IsEigenFixed<T>::value) {
      const size_t n = static_cast<size_t>(value.size());
      if (!node.IsSequence() || node.size() != n) {
        fail(node, key, "must be a list of " + std::to_string(n) + " numbers");
      }
      for (size_t i = 0; i < n; ++i) {
        read(node[i], key + "[" + std::to_string(i) + "]", value.data()[i]);
      }
    } else {
      static_assert(std::is_arithmetic_v<T> || std::is_same_v<T, std::string>,
                    "unsupported config field type");
      if (!node.IsScalar()) {
        fail(node, key, std::string("must be ") + type_name<T>());
      }
      try {
        value = node.as<T>();
      } catch (const YAML::Exception&) {
        fail(node, key, std::string("must be ") + type_name<T>() + ", got '" + node.Scalar() + "'");
      }
      if constexpr (std::is_floating_point_v<T>) {
        if (!std::isfinite(value)) {
          fail(node, key, "must be a finite number, got '" + node.Scalar() + "'");
        }
      }
    }
  }

 private:
  std::string join(const std::string& key) const {
    return key_path_.empty() ? key : key_path_ + "." + key;
  }
  std::string known_keys() const {
    std::string s = " (known keys:";
    for (const auto& k : visited_) {
      s += " " + k;
    }
    return s + ")";
  }
  [[noreturn]] void fail(const YAML::Node& node, const std::string& key,
                         const std::string& what) const {
    throw ConfigError(config_detail::location(file_, node) + ": key '" + key + "' " + what);
  }

  YAML::Node node_;
  std::string file_;
  std::string key_path_;
  std::set<std::string> visited_;
};

// Parses a YAML file; a syntax error or a missing file is a ConfigError naming the file.
YAML::Node load_yaml_file(const std::string& path);

// Reads the map at `section` of the file (the whole file if section is empty) into a
// Config, starting from its defaults. A missing section keeps every default.
template <class Config>
Config load_config(const std::string& path, const std::string& section = "") {
  const YAML::Node root = load_yaml_file(path);
  Config config;
  YamlReader reader(root, path, "");
  if (section.empty()) {
    if (root.IsNull()) {
      return config;
    }
    reader.read(root, "", config);
  } else {
    const YAML::Node node = root[section];
    if (node) {
      reader.read(node, section, config);
    }
  }
  return config;
}

// The system config's usual place, relative to the working directory.
inline constexpr const char* kDefaultConfigPath = "config/liloc.yaml";
inline constexpr const char* kConfigOptionHelp =
    "system config (YAML); without it ./config/liloc.yaml if there is one, else the built-in "
    "defaults (the paper's values; --print-config shows them)";

// The config a program runs with: the file at `path` if one was given (a missing file is an
// error); else kDefaultConfigPath if the working directory has it; else the built-in
// defaults, so that every program runs from any directory. Logs which.
template <class Config>
Config load_program_config(const std::string& path) {
  if (!path.empty() || std::filesystem::exists(kDefaultConfigPath)) {
    const std::string file = path.empty() ? kDefaultConfigPath : path;
    spdlog::info("config: {}", file);
    return load_config<Config>(file);
  }
  spdlog::info("config: the built-in defaults (no --config, no ./{})", kDefaultConfigPath);
  return Config{};
}

// Visitor that writes a config struct as YAML (the effective values, for logs and
// for `--print-config`).
class YamlWriter {
 public:
  explicit YamlWriter(YAML::Emitter& out) : out_(out) {}

  template <class T>
  void operator()(const char* key, const T& value) {
    out_ << YAML::Key << key << YAML::Value;
    write(value);
  }
  void allow(const char*) {}  // not read, so not written

  template <class T>
  void write(const T& value) {
    using namespace config_detail;
    if constexpr (IsVisitable<T>::value) {
      out_ << YAML::BeginMap;
      const_cast<T&>(value).visit_fields(*this);
      out_ << YAML::EndMap;
    } else if constexpr (IsVector<T>::value || IsStdArray<T>::value || IsEigenFixed<T>::value) {
      out_ << YAML::Flow << YAML::BeginSeq;
      for (Eigen::Index i = 0; i < static_cast<Eigen::Index>(value.size()); ++i) {
        write(value.data()[i]);
      }
      out_ << YAML::EndSeq;
    } else if constexpr (std::is_floating_point_v<T>) {
      // The shortest text that reads back as the same value: 0.6, not 0.59999999999999998.
      char text[64];
      const std::to_chars_result end = std::to_chars(text, text + sizeof(text), value);
      out_ << std::string(text, end.ptr);
    } else {
      out_ << value;
    }
  }

 private:
  YAML::Emitter& out_;
};

template <class Config>
std::string dump_config(const Config& config) {
  YAML::Emitter out;
  YamlWriter writer(out);
  writer.write(config);
  return out.c_str();
}

// As a file that load_config(path, section) reads back: the values under `section`.
template <class Config>
std::string dump_config(const Config& config, const std::string& section) {
  YAML::Emitter out;
  YamlWriter writer(out);
  out << YAML::BeginMap << YAML::Key << section << YAML::Value;
  writer.write(config);
  out << YAML::EndMap;
  return out.c_str();
}

}  // namespace liloc
