#!/usr/bin/env bash
# Regenerates the ROS 2 test bags (tests/data/ros2/) and the ROS 2 fuzz seed
# corpora (tests/fuzz/corpus/mcap, tests/fuzz/corpus/cdr) with independent
# writers: the npm packages pinned in tests/core/io/ros2/package.json (@mcap/core,
# @foxglove/rosmsg2-serialization, ...) and Python's sqlite3. Needs node >= 18,
# npm and python3; the C++ tests use the committed files and need none of them.
# The output is deterministic: rerunning it leaves git status clean.
set -euo pipefail
cd "$(dirname "$0")/.."
src=tests/core/io/ros2
out=tests/data/ros2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

cp "$src/package.json" "$src/package-lock.json" "$src/make_ros2_bags.mjs" "$work/"
(cd "$work" && npm ci --no-audit --no-fund --loglevel=error)
rm -rf "$work/out"
node "$work/make_ros2_bags.mjs" "$work/out"
python3 "$src/make_ros2_db3.py" "$work/out"

rm -rf "$out/cdr" "$out/mcap_bag" "$out/sqlite_bag" "$out"/*.mcap
mkdir -p "$out"
cp -r "$work/out/cdr" "$work/out/mcap_bag" "$work/out/sqlite_bag" "$work/out"/*.mcap "$out/"
# messages.json is only the hand-over to make_ros2_db3.py: not kept.

for corpus in mcap cdr; do
  rm -rf "tests/fuzz/corpus/$corpus"
  mkdir -p "tests/fuzz/corpus/$corpus"
done
cp "$out"/*.mcap "tests/fuzz/corpus/mcap/"
cp "$out"/cdr/*.cdr "tests/fuzz/corpus/cdr/"
echo "ROS 2 test bags written to $out (node $(node --version), npm $(npm --version))"
