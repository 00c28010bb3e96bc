#!/usr/bin/env bash
# Desktop-app figures for docs/performance.md (Xvfb, Mesa llvmpipe):
#   1. a 10-minute simulated session replayed at 10x: event-loop latency
#      (p50, p99 of the GUI tick's lateness), frames rendered, memory;
#   2. a session of about 10 M points opened and shown at full speed: time
#      to open and show, orbiting frame rate in full and with the level of
#      detail, memory;
#   3. a simulated hour replayed as fast as possible: memory at the end
#      (grows with the data only).
# Usage: scripts/gui-bench.sh [WORKDIR]   (after scripts/build.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
work=${1:-/tmp/sweepscan-gui-bench}
mkdir -p "$work"
cli=build/app/sweepscan-cli
app=build/app/sweepscan

# Back-and-forth drives along the lab: 35 s straight at 0.2 m/s, a half turn,
# back, a half turn; repeated to the wanted length.
make_scenario() {  # seconds out
  python3 - "$1" "$2" <<'PY'
import json, math, sys
seconds, out = float(sys.argv[1]), sys.argv[2]
d = json.load(open("resources/scenarios/lab.json"))
turn = {"v_mps": 0.0, "w_radps": 0.3, "duration_s": math.pi / 0.3}
leg = {"v_mps": 0.2, "w_radps": 0.0, "duration_s": 35.0}
segs, t = [], 0.0
while t < seconds:
    segs += [leg, turn]
    t += leg["duration_s"] + turn["duration_s"]
d["path"]["segments"] = segs
d["name"] = "lab back and forth %.0f s" % seconds
json.dump(d, open(out, "w"), indent=1)
PY
}

for s in 600 1950 3600; do
  if [ ! -d "$work/lab_$s.sweepscan" ]; then
    make_scenario $s "$work/lab_$s.json"
    $cli simulate --scenario "$work/lab_$s.json" --out "$work/lab_$s.ply" --overwrite > /dev/null
  fi
done

echo "## 10-minute session at 10x (60 s of it)"
xvfb-run -a -s "-screen 0 1600x1000x24" $app --replay "$work/lab_600.sweepscan" --speed 10 \
  --quit-after 60 2>/dev/null | tail -1
echo "## ~10 M points: open, show, orbit (60 frames each)"
xvfb-run -a -s "-screen 0 1600x1000x24" $app --replay "$work/lab_1950.sweepscan" --speed 0 \
  --orbit-benchmark 60 2>/dev/null | tail -1
echo "## a simulated hour, replayed as fast as possible"
xvfb-run -a -s "-screen 0 1600x1000x24" $app --replay "$work/lab_3600.sweepscan" --speed 0 \
  --orbit-benchmark 10 2>/dev/null | tail -1
