#!/usr/bin/env bash
# The outage figures of docs/robot-agent.md ("Outages and reconnection"):
# reconnection time after the link returns (50 outages), lidar data lost per
# outage length, the agent's buffer memory, and the watchdog stop under each
# fault. Real time against the simulated robot through the fault-injecting
# relay (tests/testing/fault_proxy.h); about 4 minutes.
#   scripts/link-outage-figures.sh [BUILD_DIR]
set -euo pipefail
build="${1:-build}"
test="$build/tests/hardware/link_outage_test"
[ -x "$test" ] || { echo "no $test: build the tests (cmake -DSWEEPSCAN_BUILD_TESTS=ON)" >&2; exit 1; }
"$test" --gtest_also_run_disabled_tests \
  --gtest_filter='LinkOutageTest.DISABLED_Figures:LinkOutageTest.Cuts*' 2>/dev/null | grep '^figure:'
