#pragma once
// liloc_map localize: one scan against a map directory (docs/initialization.md).

namespace liloc {

int localize_scan(int argc, const char* const* argv);

}  // namespace liloc
