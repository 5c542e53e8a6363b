#pragma once
// Where replies addressed to one robot go (the map server's submaps). On a udpm:// bus:
// the bus's multicast group on a port of the robot's own, bus port + 1 + (a hash of the
// robot id) mod reply_ports, so that a robot's socket receives no other robot's replies
// (LCM reassembles every fragmented message it receives before it looks at the channel:
// eight robots' megabyte replies on one port would fill every robot's receive buffer).
// The server and the robots compute it from the config alike; nothing on the wire names
// it. On any other bus (memq://, file://) or with reply_ports 0: the bus itself.

#include <string>

namespace liloc::node {

std::string reply_url(const std::string& bus_url, int reply_ports, const std::string& robot_id);

}  // namespace liloc::node
