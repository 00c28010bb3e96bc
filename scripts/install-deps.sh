#!/usr/bin/env bash
# Installs the Debian 12 packages sweepscan builds and tests with, if any is
# missing. Safe to run repeatedly; needs root (or sudo) only when installing.
set -euo pipefail

packages=(
  build-essential cmake ninja-build ccache pkg-config
  libeigen3-dev libceres-dev libpcl-dev libvtk9-qt-dev nlohmann-json3-dev
  libnanoflann-dev libtbb-dev libssl-dev
  qtbase5-dev libqt5serialport5-dev
  libgtest-dev libgmock-dev googletest libbenchmark-dev
  clang-14 libclang-rt-14-dev
  xvfb xauth libgl1-mesa-dri socat
  # The packages' man pages (help2man) and the checks of the unit, rules and
  # desktop entry (systemd-analyze, udevadm, ...).
  help2man systemd udev desktop-file-utils shellcheck librsvg2-bin dpkg-dev lintian
  # ROS bags (docs/ros-bags.md): ROS 1 through Debian's rosbag_storage and
  # message headers (rosbag/bag.h needs the ROS 2 pluginlib beside them);
  # ROS 2's sqlite3 and MCAP storages need sqlite3, zstd and lz4.
  librosbag-storage-dev libroscpp-core-dev libsensor-msgs-dev libnav-msgs-dev
  libgeometry-msgs-dev libtf2-msgs-dev pluginlib-dev librcpputils-dev librcutils-dev
  libament-index-cpp-dev libsqlite3-dev libzstd-dev liblz4-dev zlib1g-dev
  # The independent writers and readers the tests check against.
  python3-rosbag python3-sensor-msgs python3-nav-msgs python3-tf2-msgs python3-geometry-msgs
  # Floor plans (docs/plan-formats.md): the DXF read by ezdxf and printed by
  # LibreCAD, its PDF rasterised by pdftoppm.
  python3-ezdxf librecad poppler-utils
  # A comma-decimal locale made by localedef in the tests (the drawings must
  # not follow the desktop's LC_NUMERIC).
  locales
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
