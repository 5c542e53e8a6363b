#pragma once
// When to log a problem that may repeat at message rate: the first five times, then every
// `period`th, so that a flood of bad input stays visible without drowning the log (every
// occurrence is counted where it happens).

#include <cstdint>

namespace liloc {

// `count`: how many times the problem happened, this one included.
inline bool should_log(int64_t count, int64_t period = 100) {
  return count <= 5 || count % period == 0;
}

}  // namespace liloc
