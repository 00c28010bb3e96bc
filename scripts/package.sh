#!/usr/bin/env bash
# Builds the Debian packages into dist/ (docs/deployment.md):
#   dist/sweepscan_VERSION_amd64.deb          the workstation (app, CLI, sim, render)
#   dist/sweepscan-robotd_VERSION_amd64.deb   the robot agent for an amd64 robot/test box
#   dist/sweepscan-robotd_VERSION_arm64.deb   the robot agent for the Raspberry Pi
#   dist/sweepscan-robotd.service             the unit file, for reading
# The amd64 packages come from the full build in ./build (scripts/build.sh),
# the arm64 one from the cross-build in ./build-arm64 (scripts/build-arm64.sh).
#
#   scripts/package.sh [--amd64-only] [--build-dir DIR] [extra cmake -D options]
#     --amd64-only     skip the arm64 cross-build
#     --build-dir DIR  the amd64 build folder (default build)
# Then, as root: scripts/package-smoke.sh
set -euo pipefail
cd "$(dirname "$0")/.."

arm64=1
build_dir=build
cmake_args=()
while [ $# -gt 0 ]; do
  case "$1" in
    --amd64-only) arm64=0 ;;
    --build-dir) build_dir="$2"; shift ;;
    -h | --help) sed -n '2,16p' "$0"; exit 0 ;;
    *) cmake_args+=("$1") ;;
  esac
  shift
done

export CCACHE_DIR="${CCACHE_DIR:-$HOME/.cache/ccache}"
export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=true
jobs=$(nproc 2>/dev/null || echo 2)
host_arch=$(dpkg --print-architecture)

if ! command -v help2man >/dev/null; then
  echo "package: help2man is missing: the packages would have no man pages (apt install help2man)" >&2
  exit 1
fi
if ! command -v dpkg-shlibdeps >/dev/null; then
  echo "package: dpkg-shlibdeps is missing (apt install dpkg-dev)" >&2
  exit 1
fi

# cpack_into DIR: runs CPack (DEB) in the configured and built DIR and moves
# the packages to dist/.
cpack_into() {
  local dir="$1" out="$1/cpack"
  rm -rf "$out"
  (cd "$dir" && cpack -G DEB -B "$PWD/cpack" > cpack.log 2>&1) || {
    cat "$dir/cpack.log" >&2
    echo "package: cpack failed in $dir (log: $dir/cpack.log)" >&2
    exit 1
  }
  local n=0
  for deb in "$out"/*.deb; do
    [ -e "$deb" ] || continue
    mv -f "$deb" dist/
    n=$((n + 1))
  done
  if [ "$n" -eq 0 ]; then
    echo "package: cpack made no package in $dir" >&2
    exit 1
  fi
}

mkdir -p dist
rm -f dist/sweepscan_*.deb dist/sweepscan-robotd_*.deb dist/sweepscan-robotd.service

# --- amd64: the whole project ---------------------------------------------
echo "package: building $build_dir ($host_arch)"
if [ "$build_dir" = build ]; then
  scripts/build.sh "${cmake_args[@]}"
else
  cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "${cmake_args[@]}"
  cmake --build "$build_dir" -j"$jobs"
fi
if [ ! -x "$build_dir/app/sweepscan" ]; then
  echo "package: warning: $build_dir has no desktop app (SWEEPSCAN_BUILD_GUI=OFF?); the sweepscan package will lack it" >&2
fi
cpack_into "$build_dir"

# --- arm64: sweepscan-robotd only -----------------------------------------
if [ "$arm64" -eq 1 ]; then
  if [ -x scripts/build-arm64.sh ]; then
    echo "package: cross-building build-arm64 (scripts/build-arm64.sh)"
    scripts/build-arm64.sh  # robotd and its man page (help2man through qemu)
    if ! file -b build-arm64/app/sweepscan-robotd | grep -q "ARM aarch64"; then
      echo "package: build-arm64/app/sweepscan-robotd is not an aarch64 program" >&2
      exit 1
    fi
    cpack_into build-arm64
  else
    echo "package: no scripts/build-arm64.sh: no arm64 package" >&2
  fi
fi

cp packaging/systemd/sweepscan-robotd.service dist/sweepscan-robotd.service

echo
echo "package: made in dist/:"
for deb in dist/*.deb; do
  printf '  %-40s %8s  %s\n' "$(basename "$deb")" "$(du -h "$deb" | cut -f1)" \
    "$(dpkg-deb -f "$deb" Architecture)"
  printf '    Depends: %s\n' "$(dpkg-deb -f "$deb" Depends)"
done
printf '  %-40s %8s\n' sweepscan-robotd.service "$(du -h dist/sweepscan-robotd.service | cut -f1)"

# Lintian's view, for information (known and accepted: bogus-mail-host, the
# maintainer address is a placeholder; docs/deployment.md).
if command -v lintian >/dev/null; then
  echo
  echo "package: lintian dist/*.deb (errors and warnings):"
  lintian dist/*.deb 2>&1 | sed 's/^/  /' || true
fi
