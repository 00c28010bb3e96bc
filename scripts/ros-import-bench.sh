#!/usr/bin/env bash
# Import throughput of a one-hour ROS bag, side by side in one run with ROS's
# own readers (docs/performance.md, "ROS bags"):
#   ROS 1: `sweepscan-cli import` against rosbag's Python reader (Debian's
#          python3-rosbag) deserialising the same topics;
#   ROS 2: `sweepscan-cli import` of the same hour as MCAP (zstd) against
#          @mcap/core's reader with @foxglove/rosmsg2-serialization (node),
#          when tests/tools/node_modules is installed
#          (scripts/install-test-tools.sh).
# The hour is the simulated lab drive (55 s, X4-like 720-beam scans at 7 Hz,
# odometry 50 Hz, IMU 100 Hz, tf 50 Hz) written 65 times back to back by
# tests/tools/session_to_rosbag1.py --repeat. Elapsed time and peak resident
# memory come from /usr/bin/time; run on an otherwise idle machine.
#
#   scripts/ros-import-bench.sh [WORK_DIR]      (default /tmp/sweepscan-ros-bench)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
CLI="$ROOT/build/app/sweepscan-cli"
WORK=${1:-/tmp/sweepscan-ros-bench}
REPEAT=${REPEAT:-65}
mkdir -p "$WORK"
cd "$WORK"
[ -x "$CLI" ] || { echo "build first: scripts/build.sh" >&2; exit 2; }

if [ ! -f hour.bag ]; then
  "$CLI" simulate --scenario "$ROOT/resources/scenarios/lab.json" --out lab.ply --overwrite > /dev/null
  rm -rf csv && "$CLI" export lab.sweepscan --out csv > /dev/null
  /usr/bin/python3 "$ROOT/tests/tools/session_to_rosbag1.py" csv lab.sweepscan/meta.json hour.bag \
    --bins 720 --repeat "$REPEAT"
fi
bytes=$(stat -c %s hour.bag)
msgs=$(/usr/bin/python3 -c "import rosbag; print(rosbag.Bag('hour.bag').get_message_count())")

measure() {  # NAME COMMAND...: prints seconds, MB/s, messages/s, peak RSS
  local name=$1; shift
  /usr/bin/time -f "%e %M" -o time.txt "$@" > /dev/null 2> err.txt || { cat err.txt; exit 1; }
  read -r secs kb < time.txt
  awk -v n="$name" -v s="$secs" -v kb="$kb" -v b="$bytes" -v m="$msgs" 'BEGIN {
    printf "%-44s %7.2f s %8.1f MB/s %10.0f msg/s %7.0f MiB peak RSS\n", n, s, b / 1e6 / s, m / s, kb / 1024 }'
}

echo "ROS 1 bag: $bytes bytes, $msgs messages"
rm -rf hour.sweepscan
measure "sweepscan-cli import (ROS 1)" "$CLI" import hour.bag --out hour.sweepscan
measure "rosbag Python reader, same topics" /usr/bin/python3 -c "
import rosbag
n = 0
for _ in rosbag.Bag('hour.bag').read_messages(topics=['/scan', '/odom', '/imu/data', '/tf', '/tf_static']):
    n += 1
"

NODE_TOOLS="$ROOT/tests/tools"
if [ -d "$NODE_TOOLS/node_modules" ] && [ -f "$NODE_TOOLS/session_to_ros2.mjs" ]; then
  if [ ! -f hour.mcap ]; then
    node "$NODE_TOOLS/session_to_ros2.mjs" csv lab.sweepscan/meta.json hour.mcap --bins 720 \
      --compression zstd --repeat "$REPEAT"
  fi
  bytes=$(stat -c %s hour.mcap)
  echo "ROS 2 MCAP (zstd): $bytes bytes"
  rm -rf hour2.sweepscan
  measure "sweepscan-cli import (MCAP)" "$CLI" import hour.mcap --out hour2.sweepscan
  measure "@mcap/core + rosmsg2-serialization (node)" node "$NODE_TOOLS/read_mcap.mjs" hour.mcap
fi
