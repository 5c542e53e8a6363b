#!/usr/bin/env bash
# Fresh machine to green tests: installs what is missing, builds (Release, -j2, ccache,
# warnings as errors) and runs every test through ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
./scripts/build.sh -DLILOC_WERROR=ON
cd "${LILOC_BUILD_DIR:-build}"
ctest --output-on-failure -j2 "$@"
