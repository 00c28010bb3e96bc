#!/usr/bin/env bash
# The CLI on long sessions (docs/performance.md, "The CLI on long sessions"):
# wall time and peak resident memory of `info`, `reconstruct` (LAS and PLY),
# `repair` and `evaluate` on back-and-forth lab drives of 32.5 minutes and 10 hours
# (9.5 M and about 175 M points). Before the streaming readers the same
# commands held the decoded session and the cloud (docs/performance.md has
# those figures).
# Usage: scripts/cli-memory.sh [WORKDIR]   (after scripts/build.sh)
#   The 10-hour session takes 1.4 GB of disk; making it (simulate, which
#   holds everything) takes about 10 minutes and 12 GB of memory, once.
set -euo pipefail
cd "$(dirname "$0")/.."
work=${1:-/tmp/sweepscan-gui-bench}
cli=$PWD/build/app/sweepscan-cli
mkdir -p "$work"

# Back-and-forth drives along the lab, as scripts/gui-bench.sh makes them.
make_scenario() {  # seconds out
  python3 scripts/lab-drive.py "$1" "$2"
}

for s in 1950 36000; do
  if [ ! -d "$work/lab_$s.sweepscan" ]; then
    make_scenario $s "$work/lab_$s.json"
    $cli simulate --scenario "$work/lab_$s.json" --out "$work/lab_$s.ply" --overwrite > /dev/null
    rm -f "$work/lab_$s.ply"  # 32 B a point; only the session is needed here
  fi
done

measure() {  # label command...
  local t
  t=$( (/usr/bin/time -f "TIME %e s, peak %M KiB" "${@:2}" > /dev/null) 2>&1 | grep '^TIME' )
  echo "$1: ${t#TIME }"
}

echo "sweepscan-cli --version (the libraries alone)"
measure "  --version" $cli --version
for s in 1950 36000; do
  session="$work/lab_$s.sweepscan"
  echo "lab_$s ($(du -sh "$session" | cut -f1) of frames)"
  measure "  info" $cli info "$session"
  measure "  reconstruct --out LAS" $cli reconstruct "$session" --out "$work/out_$s.las"
  measure "  reconstruct --out PLY" $cli reconstruct "$session" --out "$work/out_$s.ply"
  $cli reconstruct "$session" --out "$work/out_$s.ply" --json | python3 -c '
import json, sys
r = json.load(sys.stdin)
print("  %d scans, %d samples -> %d points; poses held %.1f MiB" % (r["scans"], r["samples"], r["points"], r["memory"]["poses_mib"]))'
  rm -f "$work/out_$s.las" "$work/out_$s.ply"
  rm -rf "$work/repaired_$s.sweepscan"
  measure "  repair --out NEW" $cli repair "$session" --out "$work/repaired_$s.sweepscan"
  rm -rf "$work/repaired_$s.sweepscan"
done
measure "lab_1950 evaluate (streamed, positions only)" $cli evaluate "$work/lab_1950.sweepscan"
