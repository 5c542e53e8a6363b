#include "node/reply_route.hpp"

#include <cstdint>
#include <stdexcept>

namespace liloc::node {
namespace {
// FNV-1a: the same in every process and build, unlike std::hash.
uint32_t stable_hash(const std::string& text) {
  uint32_t h = 2166136261u;
  for (const unsigned char c : text) {
    h = (h ^ c) * 16777619u;
  }
  return h;
}
}  // namespace

std::string reply_url(const std::string& bus_url, int reply_ports, const std::string& robot_id) {
  const std::string scheme = "udpm://";
  if (reply_ports <= 0 || bus_url.rfind(scheme, 0) != 0) {
    return bus_url;
  }
  // udpm://GROUP:PORT?OPTIONS
  const size_t colon = bus_url.find(':', scheme.size());
  if (colon == std::string::npos) {
    return bus_url;  // LCM's default port: no room to count from
  }
  const size_t end = bus_url.find('?', colon);
  const std::string port_text =
      bus_url.substr(colon + 1, end == std::string::npos ? std::string::npos : end - colon - 1);
  int port = 0;
  try {
    port = std::stoi(port_text);
  } catch (const std::exception&) {
    throw std::invalid_argument("bus URL '" + bus_url + "': port '" + port_text +
                                "' is not a number");
  }
  const int reply_port =
      port + 1 + static_cast<int>(stable_hash(robot_id) % static_cast<uint32_t>(reply_ports));
  if (reply_port > 65535) {
    throw std::invalid_argument("bus URL '" + bus_url + "': reply ports run past 65535");
  }
  return bus_url.substr(0, colon + 1) + std::to_string(reply_port) +
         (end == std::string::npos ? "" : bus_url.substr(end));
}

}  // namespace liloc::node
