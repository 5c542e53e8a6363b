#include "config/yaml_config.hpp"

#include <filesystem>
#include <fstream>

namespace liloc {
namespace config_detail {

std::string location(const std::string& file, const YAML::Node& node) {
  const YAML::Mark mark = node.Mark();
  if (mark.is_null()) {
    return file;
  }
  return file + ":" + std::to_string(mark.line + 1);
}

}  // namespace config_detail

YAML::Node load_yaml_file(const std::string& path) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) {
    throw ConfigError(path + ": is a directory, not a config file");
  }
  std::ifstream stream(path);
  if (!stream) {
    throw ConfigError(path + ": cannot open config file (" +
                      (std::filesystem::exists(path, error) ? "not readable" : "no such file") +
                      ")");
  }
  try {
    return YAML::Load(stream);
  } catch (const YAML::ParserException& e) {
    throw ConfigError(path + ":" + std::to_string(e.mark.line + 1) +
                      ": YAML syntax error: " + e.msg);
  }
}

}  // namespace liloc
