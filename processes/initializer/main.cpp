// liloc_initializer: a robot's first pose in the map frame, and again when asked
// (common/initializer_node/, docs/initialization.md).
//   in:  <robot>.KEYFRAME, <robot>.COARSE_POSE, MAP.INFO, <robot>.DESCRIPTORS, <robot>.SUBMAP
//   out: <robot>.INIT, <robot>.STATUS.initializer, MAP.DESCRIPTOR_REQUEST, MAP.REQUEST

#include <cstdio>

#include "app/program.hpp"
#include "config/yaml_config.hpp"
#include "initializer_node/initializer_node.hpp"
#include "node/process_config.hpp"

int main(int argc, char** argv) {
  using namespace liloc;
  std::string config_path = "config/liloc.yaml";
  std::string robot_id = "robot0";
  std::string url;
  bool print_config = false;
  CommandLine cli("liloc_initializer",
                  "Pose initialization of one robot in the map frame: coarse-to-fine from a "
                  "coarse pose (paper Section IV-B), or global without one.");
  cli.add_option("config", &config_path, "system config (YAML)");
  cli.add_option("robot", &robot_id, "robot id: the prefix of its channels");
  cli.add_option("lcm-url", &url, "LCM URL, overrides the config");
  cli.add_flag("print-config", &print_config, "print the effective config and exit");
  return run_program(cli, "initializer", argc, argv, [&]() -> int {
    auto config = load_config<node::ProcessConfig<InitializerNodeConfig>>(config_path);
    if (!url.empty()) {
      config.transport.url = url;
    }
    if (print_config) {
      std::printf("%s\n", dump_config(config).c_str());
      return 0;
    }
    transport::Transport bus(config.transport);
    InitializerNode initializer(bus, robot_id, config.node);
    return node::run_nodes(bus, {&initializer}) ? 0 : 1;
  });
}
