#pragma once
// The configuration of a whole liloc system, one YAML file (config/liloc.yaml). Every
// process reads the whole file, so a misspelled section or key anywhere is an error in
// every process, not a silently ignored default.

#include <stdexcept>
#include <string>

#include "descriptor/polar_descriptor.hpp"
#include "map/central_session_builder.hpp"
#include "map/map_service.hpp"
#include "odometry/lidar_inertial_odometry.hpp"
#include "transport/channels.hpp"
#include "transport/transport.hpp"

namespace liloc {

struct MapServerConfig {
  std::string map_directory = "data/map";
  double cache_mb = 512.0;     // keyframe clouds held in memory
  double info_period_s = 1.0;  // MAP.INFO and status
  int keep_versions = 5;       // saved versions kept on disk
  // Threads that answer requests with clouds. Two halve the wait of a burst (robots
  // entering submaps at once) on a 2-core machine: bench_mapserver's cloud-reply p99.
  int reply_threads = 2;
  std::string status_channel = "MAP.STATUS";
  MapServiceConfig service;

  template <class V>
  void visit_fields(V& v) {
    v("map_directory", map_directory);
    v("cache_mb", cache_mb);
    v("info_period_s", info_period_s);
    v("keep_versions", keep_versions);
    v("reply_threads", reply_threads);
    v("status_channel", status_channel);
    v("service", service);
  }
  void validate() const {
    if (!(cache_mb > 0.0) || !(info_period_s > 0.0)) {
      throw std::invalid_argument("cache_mb and info_period_s must be positive");
    }
    if (keep_versions < 1) {
      throw std::invalid_argument("keep_versions must be at least 1");
    }
    if (reply_threads < 1 || reply_threads > 64) {
      throw std::invalid_argument("reply_threads must be 1 to 64, got " +
                                  std::to_string(reply_threads));
    }
  }
};

struct SystemConfig {
  transport::TransportConfig transport;
  transport::ChannelConfig channels;
  OdometryConfig odometry;
  PolarDescriptorConfig descriptor;  // the same for the map, loop closure, initialization
  MapServerConfig map_server;
  CentralSessionConfig map_builder;  // liloc_map build

  template <class V>
  void visit_fields(V& v) {
    v("transport", transport);
    v("channels", channels);
    v("odometry", odometry);
    v("descriptor", descriptor);
    v("map_server", map_server);
    v("map_builder", map_builder);
  }
};

}  // namespace liloc
