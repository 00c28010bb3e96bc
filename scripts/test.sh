#!/usr/bin/env bash
# Installs what is missing, builds everything and runs every test:
#   1. a short libFuzzer run of every fuzz target on its seed corpus
#      (clang build in ./build-fuzz; skipped with SWEEPSCAN_SKIP_FUZZ=1);
#   2. the arm64 cross-build of sweepscan-robotd (./build-arm64), which the
#      suite runs under qemu-aarch64-static (robotd_process_test);
#   3. the GoogleTest suites through CTest (gcc build in ./build);
#   4. the Debian packages, installed, run and removed (scripts/package-smoke.sh).
# GUI tests, when present, run under xvfb-run.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
# The independent ROS 2 writers the import tests check against (npm).
scripts/install-test-tools.sh
jobs=$(nproc 2>/dev/null || echo 2)
export CCACHE_DIR="${CCACHE_DIR:-$HOME/.cache/ccache}"
# Let clones at other paths (CI checks out afresh) share the cache.
export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=true


if [ "${SWEEPSCAN_SKIP_FUZZ:-0}" != "1" ]; then
  CC=clang-14 CXX=clang++-14 cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DSWEEPSCAN_BUILD_FUZZERS=ON -DSWEEPSCAN_BUILD_TESTS=ON -DSWEEPSCAN_BUILD_BENCHMARKS=OFF \
    -DSWEEPSCAN_BUILD_GUI=OFF > build-fuzz.log 2>&1 || { cat build-fuzz.log; exit 1; }
  fuzz_targets=$(cmake --build build-fuzz --target help | sed -n 's/^\([a-z0-9_]*_fuzz\):.*/\1/p')
  # shellcheck disable=SC2086
  cmake --build build-fuzz -j"$jobs" --target $fuzz_targets
  (cd build-fuzz && ctest --output-on-failure -R '_fuzz_smoke$')
fi

scripts/build-arm64.sh

scripts/build.sh -DSWEEPSCAN_BUILD_TESTS=ON -DSWEEPSCAN_BUILD_BENCHMARKS=ON -DSWEEPSCAN_WERROR=ON \
  -DSWEEPSCAN_ROBOTD_ARM64="$PWD/build-arm64/app/sweepscan-robotd"
scripts/check-service-files.sh
if [ "${SWEEPSCAN_SKIP_PACKAGES:-0}" != "1" ]; then
  scripts/package.sh
  # Installs, runs and purges the packages: root only (CI is root).
  if [ "$(id -u)" -eq 0 ]; then
    scripts/package-smoke.sh
  else
    echo "test: not root: skipping scripts/package-smoke.sh (run it with sudo)"
  fi
fi
# The main suite last, so its summary closes the output. One Xvfb serves every
# GUI test; -noreset keeps it from resetting when its last client leaves, as
# it does by default: a test connecting during that reset is refused ("could
# not connect to display"), which two loops of xdpyinfo show ~5 % of the time.
(cd build && xvfb-run -a -s "-screen 0 1280x1024x24 -noreset" ctest --output-on-failure -j"$jobs" --timeout 600)
