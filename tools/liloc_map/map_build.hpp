#pragma once
// liloc_map build LOG OUT_DIR: the central session from a recorded drive.

namespace liloc {

int build_map(int argc, const char* const* argv);

}  // namespace liloc
