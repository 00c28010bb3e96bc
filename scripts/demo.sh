#!/usr/bin/env bash
# Installs what is missing, builds, and runs the main job: the desktop app on
# the built-in simulated robot.
#   - With a display: opens sweepscan connected to the simulator; drive with
#     the arrow keys, record with Ctrl+R, Space is the emergency stop.
#   - Without a display (CI, ssh): runs the scripted demo under Xvfb: the app
#     records and drives the lab scenario's path for 60 s, then writes
#     out/demo.png (the view), out/demo.ply (the cloud) and the session under
#     out/sessions/, and prints a one-line JSON summary.
# Extra arguments go to sweepscan (e.g. --scenario FILE, --quit-after S).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh -DSWEEPSCAN_BUILD_TESTS=OFF -DSWEEPSCAN_BUILD_BENCHMARKS=OFF
mkdir -p out
if [ -n "${DISPLAY:-}" ] && [ "${SWEEPSCAN_HEADLESS:-0}" != "1" ]; then
  exec build/app/sweepscan --simulate --sessions-dir out/sessions "$@"
fi
rm -f out/demo.png out/demo.ply
xvfb-run -a -s "-screen 0 1600x1000x24" build/app/sweepscan --drive-demo \
  --scenario resources/scenarios/lab.json --sessions-dir out/sessions \
  --screenshot out/demo.png --export-cloud out/demo.ply --quit-after 60 "$@"
