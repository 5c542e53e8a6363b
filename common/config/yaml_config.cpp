#include "config/yaml_config.hpp"

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
  std::ifstream stream(path);
  if (!stream) {
    throw ConfigError(path + ": cannot open config file");
  }
  try {
    return YAML::Load(stream);
  } catch (const YAML::ParserException& e) {
    throw ConfigError(path + ":" + std::to_string(e.mark.line + 1) +
                      ": YAML syntax error: " + e.msg);
  }
}

}  // namespace liloc
