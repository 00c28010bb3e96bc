#!/usr/bin/env bash
# Behaviour check for refactorings: runs the README's sweepscan-cli commands
# (and a few error paths) with two binaries, each in its own temp folder, and
# compares what they print (stdout, stderr, exit code) and every file they
# write (clouds, sessions, truth, calibration files, CSV) byte for byte.
#
#   scripts/check-cli-unchanged.sh OLD_CLI NEW_CLI
#
# Output that may differ only in a session's creation time (info, meta.json)
# is compared with ISO timestamps masked, and text whose numbers differ
# only within 1e-6 relative (a sum in another order) is accepted; the report
# says where either was needed. Prints PASS or FAIL at the end and exits 0 or 1. About a minute
# per binary on a small machine.
set -u

if [ $# -ne 2 ] || [ ! -x "$1" ] || [ ! -x "$2" ]; then
  echo "usage: $0 OLD_CLI NEW_CLI (two sweepscan-cli executables)" >&2
  exit 2
fi
OLD=$(realpath "$1")
NEW=$(realpath "$2")
ROOT=$(cd "$(dirname "$0")/.." && pwd)
S="$ROOT/resources/scenarios"
WORK=$(mktemp -d /tmp/check-cli-unchanged.XXXXXX)
trap 'rm -rf "$WORK"' EXIT

# World picks at the diamond target's four corners, the same in both passes
# (as tests/app/cli_calibrate_test.cc picks them; no pairs file is kept in
# the repository), and three pick files that must be refused.
write_pairs() {
  python3 - <<'EOF'
import json, math
h = 0.3 * math.sqrt(2.0)
corners = [(5.0, 0.16, 1.35 + h), (5.0 + h, 0.16, 1.35), (5.0, 0.16, 1.35 - h), (5.0 - h, 0.16, 1.35)]
def pairs(picks):
    return json.dumps({"format": "sweepscan-pairs", "version": 1,
                       "pairs": [{"pass1": p, "pass2": p} for p in picks]})
world = lambda c: {"world": [round(v, 4) for v in c]}
open("pairs.json", "w").write(pairs([world(c) for c in corners]))
open("three.json", "w").write(pairs([world(c) for c in corners[:3]]))
open("nowhere.json", "w").write(pairs([world((50.0 + k, 50.0, 50.0)) for k in range(4)]))
open("badsample.json", "w").write(pairs([{"scan": 4000000 + k, "beam": 1} for k in range(4)]))
EOF
}

# The commands, one per line: NAME ARGS... (run from the binary's folder).
COMMANDS=(
  "simulate-lab simulate --scenario $S/lab.json --out lab.ply --truth truth.json"
  "simulate-lab-direct simulate --scenario $S/lab.json --out lab-direct.ply --direct --json"
  "simulate-ghost simulate --scenario $S/lab_circle.json --out ghost.ply"
  "info info lab.sweepscan"
  "info-json info lab.sweepscan --json"
  "reconstruct reconstruct lab.sweepscan --out lab-again.ply --no-deskew"
  "export export lab.sweepscan --out lab-csv"
  "calibrate-auto calibrate ghost.sweepscan --auto --out calib.json"
  "calibrate-auto-json calibrate ghost.sweepscan --auto --json"
  "evaluate evaluate ghost.sweepscan --calibration calib.json"
  "evaluate-json evaluate ghost.sweepscan --calibration calib.json --json"
  "evaluate-cloud evaluate ghost.ply"
  "simulate-diamond simulate --scenario $S/lab_circle_diamond.json --out diamond.ply"
  "calibrate-pairs calibrate diamond.sweepscan --pairs pairs.json --json"
  "calibrate-refine calibrate diamond.sweepscan --pairs pairs.json --refine --out calib-refined.json"
  "calibrate-refine-json calibrate diamond.sweepscan --pairs pairs.json --refine --json"
  "calibrate-scenario calibrate --scenario $S/lab_circle.json --auto --pose-source truth --json"
  "bad-three-pairs calibrate diamond.sweepscan --pairs three.json"
  "bad-no-valid-pick calibrate diamond.sweepscan --pairs badsample.json"
  "bad-picks-nowhere calibrate diamond.sweepscan --pairs nowhere.json"
  "bad-refine-nowhere calibrate diamond.sweepscan --pairs nowhere.json --refine"
  "bad-usage calibrate diamond.sweepscan"
)

run_all() {  # BIN DIR
  local bin=$1 dir=$2 line name i=0
  mkdir -p "$dir/_out"
  (
    cd "$dir" || exit 1
    write_pairs
    for line in "${COMMANDS[@]}"; do
      i=$((i + 1))
      name=$(printf '%02d-%s' "$i" "${line%% *}")
      # shellcheck disable=SC2086
      "$bin" ${line#* } >"_out/$name.stdout" 2>"_out/$name.stderr"
      echo $? >"_out/$name.rc"
    done
  )
}

mask() { sed -E 's/[0-9]{4}-[0-9]{2}-[0-9]{2}T[0-9]{2}:[0-9]{2}:[0-9]{2}(\.[0-9]+)?Z/<TIME>/g' "$1"; }

start=$(date +%s)
echo "old: $OLD"
echo "new: $NEW"
run_all "$OLD" "$WORK/old"
run_all "$NEW" "$WORK/new"

fail=0
masked=()
near=()
checked=0
# Text that differs only in numbers within 1e-6 relative (or 1e-12 absolute):
# the same computation summed in another order (e.g. the evaluation's
# threaded passes). Reported as a note, not a failure.
numbers_close() {  # FILE-A FILE-B
  python3 - "$1" "$2" <<'PY'
import re, sys
num = re.compile(r'-?\d+\.?\d*(?:[eE][-+]?\d+)?')
a, b = (open(f, errors="replace").read() for f in sys.argv[1:3])
if num.sub("#", a) != num.sub("#", b):
    sys.exit(1)
for x, y in zip(num.findall(a), num.findall(b)):
    x, y = float(x), float(y)
    if abs(x - y) > max(1e-12, 1e-6 * max(abs(x), abs(y))):
        sys.exit(1)
PY
}
compare() {  # RELATIVE-PATH
  local rel=$1 a="$WORK/old/$1" b="$WORK/new/$1"
  checked=$((checked + 1))
  if [ ! -e "$b" ]; then
    echo "FAIL  $rel: missing in the new run"
    fail=1
  elif cmp -s "$a" "$b"; then
    :
  elif cmp -s <(mask "$a") <(mask "$b"); then
    masked+=("$rel")
  elif grep -qI . "$a" 2>/dev/null && numbers_close <(mask "$a") <(mask "$b"); then
    near+=("$rel")
  else
    echo "FAIL  $rel differs:"
    if grep -qI . "$a" 2>/dev/null; then
      diff <(mask "$a") <(mask "$b") | head -20 | sed 's/^/        /'
    else
      cmp "$a" "$b" | sed 's/^/        /'
    fi
    fail=1
  fi
}

while IFS= read -r rel; do
  compare "$rel"
done < <(cd "$WORK/old" && find . -type f ! -name '*.json.tmp*' | sed 's|^\./||' | sort)
# Nothing the new binary wrote that the old one did not.
extra=$(comm -13 <(cd "$WORK/old" && find . -type f | sort) <(cd "$WORK/new" && find . -type f | sort))
if [ -n "$extra" ]; then
  echo "FAIL  files only the new binary wrote:"
  echo "$extra" | sed 's/^/        /'
  fail=1
fi

clouds=$(cd "$WORK/old" && find . -name '*.ply' | wc -l)
echo "compared $checked files ($clouds clouds, ${#COMMANDS[@]} commands' stdout/stderr/exit code) in $(( $(date +%s) - start )) s"
for rel in "${masked[@]}"; do echo "note  $rel: identical once timestamps are masked"; done
for rel in "${near[@]}"; do echo "note  $rel: numbers equal within 1e-6 relative (summation order)"; done
if [ $fail -eq 0 ]; then
  echo "PASS: the two CLIs print the same and write byte-identical files"
  exit 0
fi
echo "FAIL: see above"
exit 1
