#pragma once
// The main() of a process that runs one node for one robot (odometry, initializer,
// optimizer): its options, its config sections (ProcessConfig), the transport, run_nodes.

#include <cstdio>
#include <string>

#include "app/program.hpp"
#include "config/yaml_config.hpp"
#include "node/node.hpp"
#include "node/process_config.hpp"

namespace liloc::node {

// NodeType(Transport&, robot_id, NodeConfig); `process` names its logs ("odometry").
template <class NodeType, class NodeConfig>
int run_robot_process(const std::string& process, const std::string& description, int argc,
                      char** argv) {
  std::string config_path;  // see kConfigOptionHelp
  std::string robot_id = "robot0";
  std::string url;
  std::string publish_url;
  bool print_config = false;
  CommandLine cli("liloc_" + process, description);
  cli.add_option("config", &config_path, kConfigOptionHelp);
  cli.add_option("robot", &robot_id, "robot id: the prefix of its channels");
  cli.add_option("lcm-url", &url,
                 "LCM URL, overrides the config (file:///x.lcmlog?speed=0 replays a log)");
  cli.add_option("publish-url", &publish_url,
                 "publish here instead (file:///out.lcmlog?mode=w writes a log)");
  cli.add_flag("print-config", &print_config, "print the effective config and exit");
  return run_program(cli, process, argc, argv, [&]() -> int {
    auto config = load_program_config<ProcessConfig<NodeConfig>>(config_path);
    if (!url.empty()) {
      config.transport.url = url;
    }
    if (!publish_url.empty()) {
      config.transport.publish_url = publish_url;
    }
    if (print_config) {
      std::printf("%s\n", dump_config(config).c_str());
      return 0;
    }
    transport::Transport bus(config.transport);
    NodeType node(bus, robot_id, config.node);
    return run_nodes(bus, {&node}) ? 0 : 1;
  });
}

}  // namespace liloc::node
