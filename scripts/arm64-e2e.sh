#!/usr/bin/env bash
# The arm64 robotd end to end, here under qemu-aarch64-static, with the
# figures docs/performance.md ("The robot agent on arm64") quotes:
#   1. cross-builds robotd (scripts/build-arm64.sh) and prints what it links;
#   2. builds the amd64 tree's robotd_process_test pointed at that binary;
#   3. runs it: the simulator's byte-exact X4, HI219 and motor board on
#      pseudo-terminals, the amd64 and the arm64 robotd on the same device
#      bytes, recorded by the app's recorder and by `sweepscan-cli record`
#      (identical sensor records), the round trip, the CPU robotd takes under
#      emulation, the watchdog's stop time, the config file and the service
#      notifications (READY=1, WATCHDOG=1, STOPPING=1).
# CI runs the same test inside the suite (scripts/test.sh); this prints the
# figures alone. Usage: scripts/arm64-e2e.sh [repetitions, default 3]
set -euo pipefail
cd "$(dirname "$0")/.."
runs="${1:-3}"
scripts/build-arm64.sh
export CCACHE_DIR="${CCACHE_DIR:-$HOME/.cache/ccache}"
export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=true
cmake -S . -B build -G Ninja -DSWEEPSCAN_BUILD_TESTS=ON \
  -DSWEEPSCAN_ROBOTD_ARM64="$PWD/build-arm64/app/sweepscan-robotd" > /dev/null
cmake --build build -j"$(nproc 2>/dev/null || echo 2)" --target robotd_process_test sweepscan-cli
echo "qemu: $(qemu-aarch64-static --version | head -1)"
echo "machine: $(nproc) cores, $(sed -n 's/^model name\s*: //p' /proc/cpuinfo | head -1)"
# The test's exit status decides: a grep at the end of a pipe hid it (and
# `|| true` hid a run that printed no figure), so failing runs passed.
log=$(mktemp)
trap 'rm -f "$log"' EXIT
failed=0
for i in $(seq "$runs"); do
  echo "--- run $i"
  rc=0
  build/tests/hardware/robotd_process_test >"$log" 2>&1 || rc=$?
  grep -E '^figure:|FAILED|^\[  PASSED' "$log" || true  # What to show; not the verdict.
  if [ "$rc" -ne 0 ]; then
    echo "run $i failed (exit $rc):"
    grep -E -B2 -A6 'Failure|FAILED' "$log" | head -n 60 || tail -n 40 "$log"
    failed=$((failed + 1))
  fi
done
if [ "$failed" -ne 0 ]; then
  echo "$failed of $runs runs failed" >&2
  exit 1
fi
