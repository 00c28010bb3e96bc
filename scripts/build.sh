#!/usr/bin/env bash
# Configures and builds sweepscan into ./build (RelWithDebInfo, Ninja, ccache).
# Extra arguments go to CMake, e.g. scripts/build.sh -DSWEEPSCAN_BUILD_GUI=OFF
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "$@"
cmake --build build -j"$jobs"
