#!/usr/bin/env bash
# Configures and builds liloc (Release, ccache, -j2) into build/. Extra arguments go to
# cmake's configure step, e.g. ./scripts/build.sh -DLILOC_WERROR=ON
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${LILOC_BUILD_DIR:-build}
JOBS=${LILOC_JOBS:-2}
export CCACHE_DIR=${CCACHE_DIR:-$HOME/.cache/ccache}
export CCACHE_MAXSIZE=${CCACHE_MAXSIZE:-5G}
cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
cmake --build "$BUILD_DIR" -j"$JOBS"
