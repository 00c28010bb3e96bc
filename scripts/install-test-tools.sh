#!/usr/bin/env bash
# Installs the npm packages of the independent ROS 2 test writers
# (tests/tools/package-lock.json: @mcap/core, @foxglove/rosmsg2-serialization,
# ...) into tests/tools/node_modules, when that is missing or older than the
# lock file. Safe to run repeatedly: silent when nothing is to do.
set -euo pipefail
cd "$(dirname "$0")/../tests/tools"
if ! command -v node > /dev/null || ! command -v npm > /dev/null; then
  echo "install-test-tools: installing Debian's nodejs and npm"
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends nodejs npm > /dev/null
fi
# npm ci writes node_modules/.package-lock.json last: its age is the install's.
stamp=node_modules/.package-lock.json
if [ -f "$stamp" ] && [ ! package-lock.json -nt "$stamp" ] && [ ! package.json -nt "$stamp" ]; then
  exit 0
fi
echo "install-test-tools: npm ci in tests/tools"
npm ci --no-audit --no-fund --loglevel=error > /dev/null ||
  { echo "install-test-tools: npm ci failed in $PWD" >&2; exit 1; }
