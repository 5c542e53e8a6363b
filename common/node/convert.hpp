#pragma once
// Messages are converted to core types at a node's door (bridge/): what does not convert
// is counted and logged (rate-limited) with the reason, and goes no further.

#include <spdlog/spdlog.h>

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>

#include "app/rate_limit.hpp"

namespace liloc::node {

// convert_msg(msg), or none if it throws std::invalid_argument (counted in `rejected`).
template <class Msg, class Convert>
auto convert(const Msg& msg, Convert convert_msg, int64_t& rejected, const std::string& what)
    -> std::optional<decltype(convert_msg(msg))> {
  try {
    return convert_msg(msg);
  } catch (const std::invalid_argument& e) {
    if (should_log(++rejected)) {
      spdlog::warn("{} refused: {} ({} messages refused so far)", what, e.what(), rejected);
    }
    return std::nullopt;
  }
}

}  // namespace liloc::node
