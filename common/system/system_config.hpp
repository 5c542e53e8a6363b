#pragma once
// The configuration of a whole liloc system, one YAML file (config/liloc.yaml). Every
// process reads the whole file, so a misspelled section or key anywhere is an error in
// every process, not a silently ignored default.

#include "odometry/lidar_inertial_odometry.hpp"
#include "transport/channels.hpp"
#include "transport/transport.hpp"

namespace liloc {

struct SystemConfig {
  transport::TransportConfig transport;
  transport::ChannelConfig channels;
  OdometryConfig odometry;

  template <class V>
  void visit_fields(V& v) {
    v("transport", transport);
    v("channels", channels);
    v("odometry", odometry);
  }
};

}  // namespace liloc
