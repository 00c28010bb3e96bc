#!/usr/bin/env bash
# Desktop-app figures for docs/performance.md (Xvfb, Mesa llvmpipe):
#   1. a 10-minute simulated session replayed at 10x: event-loop latency
#      (p50, p99 of the GUI tick's lateness), frames rendered, memory;
#   2. sessions of about 10 M and 100 M points (a 32.5-minute and a
#      5.7-hour drive) opened and shown at full speed: time to open and
#      show, orbiting frame rates at the rest and the motion level, time
#      back to the rest level, picks, memory (resident, peak, the cloud
#      store's, VTK's points, the heap);
#   3. the 100 M session under a 1 GiB memory budget (paged to disk);
#   4. the 100 M session replayed at 20x for 580 s (to ~54 M points,
#      issue 28's "into 50 M"): event-loop latency while the cloud grows;
#   5. CloudCompare (Debian's `cloudcompare`) opening the same clouds as
#      PLY, `-SILENT -O`: its wall time and peak resident memory;
#   6. seeking the 10 M and 100 M sessions' replays to near their ends
#      (`--seek`): the seek's time, event-loop latency, peak memory;
#   7. the office floor as a project (rooms a and b, b aligned to a): the
#      project's sessions drawn as the view's layers, open and show, orbit
#      at both levels, the rest passes, picks, memory;
#   8. the view's live insertion alone (tests/bench/
#      view_insertion_benchmark.cc): GUI seconds an hour of X4 points, live
#      and at 20x, no display and no renderer in the way.
# Usage: scripts/gui-bench.sh [WORKDIR] [SECTIONS]   (after scripts/build.sh)
#   SECTIONS: any of 1..8 (default all), e.g. "2 5". The sessions take
#   ~20 GB of disk in WORKDIR, made once (simulate: ~4 minutes for 100 M).
set -euo pipefail
cd "$(dirname "$0")/.."
work=${1:-/tmp/sweepscan-gui-bench}
sections=${2:-1 2 3 4 5 6 7 8}
want() { [[ " $sections " == *" $1 "* ]]; }
mkdir -p "$work"
cli=build/app/sweepscan-cli
app=build/app/sweepscan

# Back-and-forth drives along the lab: 35 s straight at 0.2 m/s, a half turn,
# back, a half turn; repeated to the wanted length.
make_scenario() {  # seconds out
  python3 scripts/lab-drive.py "$1" "$2"
}

for s in 600 1950 20400; do
  if [[ "$sections" =~ [1-6] ]] && [ ! -d "$work/lab_$s.sweepscan" ]; then
    make_scenario $s "$work/lab_$s.json"
    $cli simulate --scenario "$work/lab_$s.json" --out "$work/lab_$s.ply" --overwrite > /dev/null
  fi
done

gui() { xvfb-run -a -s "-screen 0 1600x1000x24" $app "$@" 2>/dev/null | tail -1; }

if want 1; then
  echo "## 10-minute session at 10x (60 s of it)"
  gui --replay "$work/lab_600.sweepscan" --speed 10 --quit-after 60
fi
if want 2; then
  for s in 1950 20400; do
    echo "## lab_$s: open, show, orbit (30 frames at each level), picks"
    gui --replay "$work/lab_$s.sweepscan" --speed 0 --orbit-benchmark 30
  done
fi
if want 3; then
  echo "## lab_20400 under --memory-budget 1024 (MiB)"
  gui --replay "$work/lab_20400.sweepscan" --speed 0 --orbit-benchmark 30 --memory-budget 1024
fi
if want 4; then
  echo "## lab_20400 replayed at 20x for 580 s (into 54 M points)"
  gui --replay "$work/lab_20400.sweepscan" --speed 20 --quit-after 580
fi
if want 5; then
  if ! command -v CloudCompare > /dev/null; then
    echo "CloudCompare is not installed (apt-get install cloudcompare)" >&2
    exit 1
  fi
  for s in 1950 20400; do
    echo "## CloudCompare -SILENT -O lab_$s.ply"
    # -SILENT still makes a QApplication: the offscreen platform serves it.
    ( cd "$work" && QT_QPA_PLATFORM=offscreen /usr/bin/time -f "wall %e s, peak resident %M KiB" \
        CloudCompare -SILENT -NO_TIMESTAMP -O "lab_$s.ply" 2>&1 | tail -1 )
  done
fi
if want 6; then
  echo "## lab_1950 seeking to 1 900 s, then 1x"
  gui --replay "$work/lab_1950.sweepscan" --speed 0 --seek 1900 --quit-after 30
  echo "## lab_20400 seeking to 20 000 s, then 1x"
  gui --replay "$work/lab_20400.sweepscan" --speed 0 --seek 20000 --quit-after 100
fi
if want 7; then
  echo "## the office floor's project (a, and b aligned to it): open, show, orbit"
  for d in a b; do
    if [ ! -d "$work/building_$d.sweepscan" ]; then
      $cli simulate --scenario "resources/scenarios/building_$d.json" --out "$work/building_$d.ply" \
        --session "$work/building_$d.sweepscan" --overwrite > /dev/null
    fi
  done
  project="$work/floor.sweepscan-project"
  if [ ! -f "$project" ]; then
    $cli project new "$project" "$work/building_a.sweepscan" "$work/building_b.sweepscan" > /dev/null
    $cli project align --session building_b --to building_a "$project" > /dev/null
  fi
  gui --project "$project" --orbit-benchmark 30
fi
if want 8; then
  echo "## the view's live insertion alone (view_insertion_benchmark)"
  build/tests/view_insertion_benchmark
fi
