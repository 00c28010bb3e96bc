#!/usr/bin/env bash
# Installs what is missing, builds, and runs the main job: the headless CLI
# on the simulated lab (the desktop app will take over this script once it
# exists). Writes out/lab.ply, out/lab.sweepscan (the recorded session) and
# out/lab-truth.json; a second run replaces them.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh -DSWEEPSCAN_BUILD_TESTS=OFF -DSWEEPSCAN_BUILD_BENCHMARKS=OFF
mkdir -p out
build/app/sweepscan-cli simulate --scenario resources/scenarios/lab.json \
  --out out/lab.ply --truth out/lab-truth.json --overwrite "$@"
