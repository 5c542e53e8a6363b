// liloc_odometry: LiDAR-inertial odometry for one robot (common/odometry_node/).
//   in:  <robot>.IMU, <robot>.LIDAR, <robot>.CORRECTION
//   out: <robot>.ODOM (every sweep), <robot>.KEYFRAME, <robot>.STATUS.odometry

#include <cstdio>

#include "app/program.hpp"
#include "config/yaml_config.hpp"
#include "node/process_config.hpp"
#include "odometry_node/odometry_node.hpp"

int main(int argc, char** argv) {
  using namespace liloc;
  std::string config_path = "config/liloc.yaml";
  std::string robot_id = "robot0";
  std::string url;
  std::string publish_url;
  bool print_config = false;
  CommandLine cli("liloc_odometry", "LiDAR-inertial odometry (the ILM front end) for one robot.");
  cli.add_option("config", &config_path, "system config (YAML)");
  cli.add_option("robot", &robot_id, "robot id: the prefix of its channels");
  cli.add_option("lcm-url", &url,
                 "LCM URL, overrides the config (file:///x.lcmlog?speed=0 "
                 "replays a log)");
  cli.add_option("publish-url", &publish_url,
                 "publish here instead (file:///out.lcmlog?mode=w writes a log)");
  cli.add_flag("print-config", &print_config, "print the effective config and exit");
  return run_program(cli, "odometry", argc, argv, [&]() -> int {
    auto config = load_config<node::ProcessConfig<OdometryNodeConfig>>(config_path);
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
    OdometryNode odometry(bus, robot_id, config.node);
    return node::run_nodes(bus, {&odometry}) ? 0 : 1;
  });
}
