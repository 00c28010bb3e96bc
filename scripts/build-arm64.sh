#!/usr/bin/env bash
# Cross-builds sweepscan-robotd for arm64 (the robot's Raspberry Pi) on this
# Debian 12 amd64 machine with Debian's multiarch and leaves it in
# build-arm64/app/sweepscan-robotd. Installs what it needs if missing (root or
# sudo): the arm64 architecture, crossbuild-essential-arm64, the :arm64
# development packages robotd links (QtCore/Network/SerialPort, OpenSSL)
# and qemu-user-static to run the result here
# (docs/deployment.md, "Cross-building for arm64").
#   scripts/build-arm64.sh [extra cmake -D options]
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(crossbuild-essential-arm64 qemu-user-static file pkg-config cmake ninja-build ccache help2man
          qtbase5-dev-tools qtbase5-dev:arm64 libqt5serialport5-dev:arm64 libssl-dev:arm64)
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
if ! dpkg --print-foreign-architectures | grep -qx arm64; then
  echo "build-arm64: adding the arm64 architecture (dpkg --add-architecture arm64)"
  $SUDO dpkg --add-architecture arm64
  $SUDO apt-get update -qq
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "build-arm64: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

export CCACHE_DIR="${CCACHE_DIR:-$HOME/.cache/ccache}"
export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=true
cmake -S . -B build-arm64 -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_TOOLCHAIN_FILE="$PWD/cmake/toolchains/aarch64-linux-gnu.cmake" \
  -DSWEEPSCAN_ROBOT_ONLY=ON -DSWEEPSCAN_WERROR=ON "$@" > build-arm64.configure.log 2>&1 \
  || { cat build-arm64.configure.log; exit 1; }
# Everything the robot-only tree has: robotd and its man page (help2man runs
# it under qemu), which the package needs.
cmake --build build-arm64 -j"$(nproc 2>/dev/null || echo 2)"

bin=build-arm64/app/sweepscan-robotd
file -b "$bin" | grep -q "ARM aarch64" || { echo "build-arm64: $bin is not an aarch64 binary" >&2; exit 1; }
echo "build-arm64: $bin: $(file -b "$bin" | cut -d, -f1-2)"
stripped=$(mktemp)
aarch64-linux-gnu-strip -o "$stripped" "$bin"
echo "build-arm64: $(stat -c %s "$bin") bytes with debug information, $(stat -c %s "$stripped") stripped; links:"
rm -f "$stripped"
aarch64-linux-gnu-readelf -d "$bin" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/  \1/p'
echo "build-arm64: $(qemu-aarch64-static -L / "$bin" --version)  (run under qemu-aarch64-static)"
