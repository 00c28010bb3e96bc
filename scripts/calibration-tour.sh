#!/usr/bin/env bash
# The desktop app's calibration workflow and evaluation, step by step, as
# window screenshots for docs/desktop-app.md and the README:
#   1. record the simulated diamond calibration drive through the bytes
#      (sweepscan-cli simulate, resources/scenarios/lab_circle_diamond.json);
#   2. write a pairs file with world picks of the board's four corners (both
#      passes; the panel's refine snaps them to the fitted corners);
#   3. run `sweepscan --replay SESSION --pairs PAIRS --calibration-tour DIR`
#      under Xvfb: passes, pass A, pass B, solved, calibrated, evaluation.
# Usage: scripts/calibration-tour.sh [OUTDIR] [WORKDIR]   (after scripts/build.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-docs/screenshots}
work=${2:-/tmp/sweepscan-calibration-tour}
mkdir -p "$work" "$out"
cli=build/app/sweepscan-cli
app=build/app/sweepscan

if [ ! -d "$work/diamond.sweepscan" ]; then
  $cli simulate --scenario resources/scenarios/lab_circle_diamond.json \
    --out "$work/diamond.ply" --overwrite > /dev/null
fi
# The diamond: centre (5.0, 0.16, 1.35), half-diagonal 0.3 * sqrt(2) m.
python3 - "$work/pairs.json" <<'PY'
import json, math, sys
c, h = (5.0, 0.16, 1.35), 0.3 * math.sqrt(2.0)
corners = [("top", (c[0], c[1], c[2] + h)), ("right", (c[0] + h, c[1], c[2])),
           ("bottom", (c[0], c[1], c[2] - h)), ("left", (c[0] - h, c[1], c[2]))]
pairs = [{"label": n, "pass1": {"world": list(p)}, "pass2": {"world": list(p)}}
         for n, p in corners]
json.dump({"format": "sweepscan-pairs", "version": 1,
           "comment": "the diamond's corners (truth), both passes", "pairs": pairs},
          open(sys.argv[1], "w"), indent=1)
PY
xvfb-run -a -s "-screen 0 1600x1000x24" "$app" --replay "$work/diamond.sweepscan" \
  --pairs "$work/pairs.json" --calibration-tour "$out"
