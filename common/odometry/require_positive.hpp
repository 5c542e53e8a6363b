#pragma once
// Config validation shared by the odometry's config structs.

#include <initializer_list>
#include <stdexcept>
#include <string>
#include <utility>

namespace liloc {

// Throws std::invalid_argument naming the first field (prefixed) that is not > 0 (or NaN).
inline void require_positive(std::initializer_list<std::pair<const char*, double>> fields,
                             const std::string& prefix = "") {
  for (const auto& [name, value] : fields) {
    if (!(value > 0.0)) {
      throw std::invalid_argument(prefix + name + " must be positive, got " +
                                  std::to_string(value));
    }
  }
}

}  // namespace liloc
