#pragma once
// The configuration of a whole liloc system, one YAML file (config/liloc.yaml), for the
// tools that use every part of it (liloc_map, the launcher). A process reads only the
// sections of its node (node/process_config.hpp) and knows the others by name, so a
// misspelled section or key is an error everywhere.

#include "descriptor/polar_descriptor.hpp"
#include "initializer_node/initializer_node.hpp"
#include "map/submap_database.hpp"
#include "map_server_node/map_server_node.hpp"
#include "mapping/central_session_builder.hpp"
#include "node/process_config.hpp"
#include "odometry_node/odometry_node.hpp"
#include "optimizer_node/optimizer_node.hpp"
#include "transport/channels.hpp"
#include "transport/transport.hpp"

namespace liloc {

struct SystemConfig {
  transport::TransportConfig transport;
  transport::ChannelConfig channels;
  SensorLimits sensors;  // what the robots' sensors can plausibly send
  OdometryConfig odometry;
  PolarDescriptorConfig descriptor;  // one for the map, loop closure and initialization
  SubmapConfig submaps;              // Eq. 2: one rule for built maps and merged updates
  MapServerConfig map_server;
  CentralSessionConfig map_builder;  // liloc_map build
  InitializerProcessConfig initializer;
  OptimizerProcessConfig optimizer;  // the joint optimizer (the egocentric factor graph)

  template <class V>
  void visit_fields(V& v) {
    v("transport", transport);
    v("channels", channels);
    v("sensors", sensors);
    v("odometry", odometry);
    v("descriptor", descriptor);
    v("submaps", submaps);
    v("map_server", map_server);
    v("map_builder", map_builder);
    v("initializer", initializer);
    v("optimizer", optimizer);
  }

  OdometryNodeConfig odometry_node() const { return {channels, sensors, odometry}; }
  MapServerNodeConfig map_server_node() const {
    return {channels, descriptor, submaps, map_server};
  }
  InitializerNodeConfig initializer_node() const { return {channels, descriptor, initializer}; }
  OptimizerNodeConfig optimizer_node() const { return {channels, descriptor, optimizer}; }
};

}  // namespace liloc
