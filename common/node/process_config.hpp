#pragma once
// What a process reads of the system config (config/liloc.yaml): the transport section and
// its node's sections. The other processes' sections are known by name and left to them,
// so that a misspelled section is still an error, a process links only what it runs, and
// --print-config shows the values the process uses.

#include <initializer_list>

#include "transport/channels.hpp"
#include "transport/transport.hpp"

namespace liloc::node {

// Every section of the system config, whichever process reads it.
inline constexpr std::initializer_list<const char*> kSystemSections = {
    "transport", "channels",   "sensors",     "odometry",    "descriptor",
    "submaps",   "map_server", "map_builder", "initializer", "optimizer"};

// Marks every system section as known to a config visitor (config/yaml_config.hpp).
template <class Visitor>
void allow_system_sections(Visitor& v) {
  for (const char* section : kSystemSections) {
    v.allow(section);
  }
}

// The config file as one process reads it: `transport`, then the node config's sections
// (NodeConfig::visit_fields names them at the top level of the file).
template <class NodeConfig>
struct ProcessConfig {
  transport::TransportConfig transport;
  NodeConfig node;

  template <class V>
  void visit_fields(V& v) {
    v("transport", transport);
    node.visit_fields(v);
    allow_system_sections(v);
  }
};

}  // namespace liloc::node
