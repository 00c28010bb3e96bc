#!/usr/bin/env bash
# The plan's time on a cloud of about 1 M points (docs/performance.md):
# drives a and b of the office floor simulated and reconstructed (true poses
# are not needed: the time depends on the points, not on their accuracy),
# merged into one PLY, then `sweepscan-cli plan` timed with SVG and DXF.
# Usage: scripts/plan-bench.sh [BUILD_DIR]   (default build)
set -euo pipefail
build=${1:-build}
cli="$build/app/sweepscan-cli"
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
for d in a b; do
  "$cli" simulate --scenario "resources/scenarios/building_$d.json" --out "$dir/$d.ply" > /dev/null
done
/usr/bin/python3 - "$dir/a.ply" "$dir/b.ply" "$dir/ab.ply" <<'PY'
import sys
def read(path):
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode()
    n = int([l for l in header.splitlines() if l.startswith("element vertex")][0].split()[2])
    return header, n, data[end:]
ha, na, ba = read(sys.argv[1])
hb, nb, bb = read(sys.argv[2])
assert ha.replace(str(na), "N") == hb.replace(str(nb), "N"), "different PLY layouts"
open(sys.argv[3], "wb").write(ha.replace("element vertex %d" % na, "element vertex %d" % (na + nb)).encode() + ba + bb)
print("points", na + nb)
PY
for run in 1 2 3; do
  /usr/bin/time -f "plan: %e s wall, %M KB peak" "$cli" plan "$dir/ab.ply" --svg "$dir/p.svg" --dxf "$dir/p.dxf" > /dev/null
done
