// liloc_map_server: serves the central session to every robot and grows it
// (common/map_server_node/).
//   in:  MAP.REQUEST (submap_request_t), MAP.UPDATE (map_update_t)
//   out: <robot>.SUBMAP (submap_t, addressed), MAP.INFO (map_info_t), MAP.STATUS

#include <cstdio>

#include "app/program.hpp"
#include "config/yaml_config.hpp"
#include "map_server_node/map_server_node.hpp"
#include "node/process_config.hpp"
#include "storage/map_store.hpp"

int main(int argc, char** argv) {
  using namespace liloc;
  std::string config_path;  // see kConfigOptionHelp
  std::string map_directory;
  std::string url;
  bool print_config = false;
  CommandLine cli("liloc_map_server", "Serves the central session's submaps to every robot.");
  cli.add_option("config", &config_path, kConfigOptionHelp);
  cli.add_option("map", &map_directory, "map directory, overrides map_server.map_directory");
  cli.add_option("lcm-url", &url, "LCM URL, overrides the config");
  cli.add_flag("print-config", &print_config, "print the effective config and exit");
  return run_program(cli, "map_server", argc, argv, [&]() -> int {
    auto config = load_program_config<node::ProcessConfig<MapServerNodeConfig>>(config_path);
    if (!map_directory.empty()) {
      config.node.map_server.map_directory = map_directory;
    }
    if (!url.empty()) {
      config.transport.url = url;
    }
    if (print_config) {
      std::printf("%s\n", dump_config(config).c_str());
      return 0;
    }
    storage::MapStore store(config.node.map_server.map_directory);
    if (!store.exists()) {
      throw std::runtime_error(config.node.map_server.map_directory +
                               ": no map (build one with liloc_map build)");
    }
    MapData map = store.load();  // a damaged map stops here, naming the file
    transport::Transport bus(config.transport);
    MapServerNode server(bus, config.node, store, std::move(map));
    return node::run_nodes(bus, {&server}) ? 0 : 1;
  });
}
