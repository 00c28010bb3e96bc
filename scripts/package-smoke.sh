#!/usr/bin/env bash
# Smoke test of the Debian packages in dist/ (made by scripts/package.sh), as
# root, on a Debian 12 machine or container; CI runs it. Installs this
# machine's sweepscan and sweepscan-robotd packages with apt (so Depends
# resolve), checks what they installed, then removes and purges them and
# checks that nothing is left. Every check prints "ok: ..."; the first
# failure prints "FAIL: ..." and exits 1. Packages already installed are
# reinstalled, and purged at the end like the others. The system user
# sweepscan stays after a purge (by design); if this script made it, it
# deletes it when done, and it removes everything else it made too, except
# dependencies apt had to install (none on a machine that built the
# packages; apt-get autoremove lists them).
#   sudo scripts/package-smoke.sh [DIST_DIR]
set -uo pipefail
cd "$(dirname "$0")/.." || exit 2
dist="${1:-dist}"

ok() { echo "ok: $*"; }
fail() {
  echo "FAIL: $*"
  exit 1
}

if [ "$(id -u)" -ne 0 ]; then
  echo "package-smoke: run as root (it installs and removes packages)" >&2
  exit 2
fi

arch=$(dpkg --print-architecture)
# newest_deb PATTERN: the last file matching the glob, or nothing.
newest_deb() {
  local last=""
  for f in "$@"; do [ -e "$f" ] && last=$f; done
  echo "$last"
}
workstation_deb=$(newest_deb "$dist"/sweepscan_*_"$arch".deb)
robotd_deb=$(newest_deb "$dist"/sweepscan-robotd_*_"$arch".deb)
arm64_deb=$(newest_deb "$dist"/sweepscan-robotd_*_arm64.deb)
[ -n "$workstation_deb" ] || fail "no $dist/sweepscan_*_$arch.deb (run scripts/package.sh)"
[ -n "$robotd_deb" ] || fail "no $dist/sweepscan-robotd_*_$arch.deb (run scripts/package.sh)"
version=$(dpkg-deb -f "$robotd_deb" Version)

work=$(mktemp -d /tmp/sweepscan-smoke.XXXXXX)
chmod 0755 "$work"
robotd_pid=""
user_existed=0
getent passwd sweepscan >/dev/null && user_existed=1
group_existed=0
getent group sweepscan >/dev/null && group_existed=1

# Leaves the system as it was found, also after a failure.
cleanup() {
  set +e
  if [ -n "$robotd_pid" ] && kill -0 "$robotd_pid" 2>/dev/null; then
    kill -KILL "$robotd_pid" 2>/dev/null
    wait "$robotd_pid" 2>/dev/null
  fi
  for p in sweepscan sweepscan-robotd; do
    if [[ "$(dpkg-query -W -f='${db:Status-Abbrev}' "$p" 2>/dev/null)" == ?[ic]* ]]; then
      dpkg -P "$p" >/dev/null 2>&1
    fi
  done
  if [ "$user_existed" -eq 0 ] && getent passwd sweepscan >/dev/null; then
    deluser --system --quiet sweepscan >/dev/null 2>&1 || userdel sweepscan
  fi
  if [ "$group_existed" -eq 0 ] && getent group sweepscan >/dev/null; then
    delgroup --system --quiet sweepscan >/dev/null 2>&1 || groupdel sweepscan
  fi
  rm -rf "$work"
}
trap cleanup EXIT

for p in sweepscan sweepscan-robotd; do
  if [ "$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null)" = "install ok installed" ]; then
    echo "note: $p is installed already: reinstalling it (and purging it at the end)"
  fi
done

# --- install ---------------------------------------------------------------
export DEBIAN_FRONTEND=noninteractive
install_debs() {
  apt-get install -y --reinstall --no-install-recommends "./$workstation_deb" "./$robotd_deb" \
    >"$work/apt.log" 2>&1
}
if ! install_debs; then
  # Missing dependencies may just need fresh package lists.
  apt-get update -qq >/dev/null 2>&1
  install_debs || { tail -n 30 "$work/apt.log"; fail "apt-get install ./$workstation_deb ./$robotd_deb"; }
fi
ok "installed $(basename "$workstation_deb") and $(basename "$robotd_deb") with apt"
if [ "$user_existed" -eq 0 ]; then
  grep -q "systemctl enable --now sweepscan-robotd" "$work/apt.log" \
    || fail "postinst did not print the hint to enable the service"
  ok "postinst printed: $(grep -m1 "systemctl enable --now" "$work/apt.log")"
fi

# --- the programs ----------------------------------------------------------
out=$(sweepscan-cli --version 2>&1) || fail "sweepscan-cli --version: $out"
[ "$out" = "sweepscan-cli $version" ] || fail "sweepscan-cli --version printed '$out', not 'sweepscan-cli $version'"
ok "sweepscan-cli --version: $out"
out=$(sweepscan-robotd --help 2>&1) || fail "sweepscan-robotd --help failed: $out"
grep -q -- "--config" <<<"$out" || fail "sweepscan-robotd --help does not mention --config"
ok "sweepscan-robotd --help (mentions --config)"
if [ -e /usr/bin/sweepscan ]; then
  out=$(env -u DISPLAY -u WAYLAND_DISPLAY timeout 60 sweepscan --help 2>&1) || fail "sweepscan --help without a display: $out"
  ok "sweepscan --help without a display"
fi
out=$(sweepscan-sim --version 2>&1) || fail "sweepscan-sim --version: $out"
ok "sweepscan-sim --version: $out"
if [ -e /usr/bin/sweepscan-render ]; then
  sweepscan-render --help >/dev/null 2>&1 || fail "sweepscan-render --help"
  ok "sweepscan-render --help"
fi
[ -f /usr/share/sweepscan/scenarios/lab.json ] || fail "/usr/share/sweepscan/scenarios/lab.json is missing"
ok "scenarios in /usr/share/sweepscan/scenarios ($(find /usr/share/sweepscan/scenarios -name '*.json' | wc -l) files)"
for page in sweepscan-cli sweepscan-robotd sweepscan-sim; do
  path=$(man -w "$page" 2>&1) || fail "man -w $page: $path"
  ok "man -w $page: $path"
done
if [ -e /usr/share/applications/sweepscan.desktop ] && command -v desktop-file-validate >/dev/null; then
  out=$(desktop-file-validate /usr/share/applications/sweepscan.desktop 2>&1)
  [ -z "$out" ] || fail "desktop-file-validate: $out"
  ok "desktop-file-validate /usr/share/applications/sweepscan.desktop"
fi

# --- user, key, configuration ----------------------------------------------
entry=$(getent passwd sweepscan) || fail "no user sweepscan"
uid=$(cut -d: -f3 <<<"$entry")
[ "$uid" -lt 1000 ] || fail "sweepscan is not a system user (uid $uid)"
groups=" $(id -nG sweepscan) "
[[ "$groups" == *" dialout "* ]] || fail "sweepscan is not in the group dialout ($groups)"
ok "system user sweepscan (uid $uid, home $(cut -d: -f6 <<<"$entry"), groups $(id -nG sweepscan))"
key=/etc/sweepscan/robotd.key
[ -f "$key" ] || fail "$key is missing"
st=$(stat -c '%a %U:%G %s' "$key")
[ "$st" = "400 sweepscan:sweepscan 32" ] || fail "$key is '$st', not '400 sweepscan:sweepscan 32'"
ok "$key: mode 400, sweepscan:sweepscan, 32 bytes"
conffiles=$(dpkg-query -W -f='${Conffiles}\n' sweepscan-robotd)
grep -q " /etc/sweepscan/robotd.conf " <<<"$conffiles" || fail "/etc/sweepscan/robotd.conf is not a conffile"
ok "/etc/sweepscan/robotd.conf is a conffile"

# --- the unit --------------------------------------------------------------
unit=/lib/systemd/system/sweepscan-robotd.service
[ -f "$unit" ] || fail "$unit is missing"
systemd-analyze verify "$unit" >"$work/verify.out" 2>"$work/verify.err"
rc=$?
if grep -qi "sweepscan" "$work/verify.err" "$work/verify.out"; then
  cat "$work/verify.err" "$work/verify.out"
  fail "systemd-analyze verify $unit reports on our unit"
fi
[ "$rc" -eq 0 ] || { cat "$work/verify.err"; fail "systemd-analyze verify $unit exited $rc"; }
if [ -s "$work/verify.err" ]; then
  sed 's/^/  (not about sweepscan) /' "$work/verify.err"
fi
ok "systemd-analyze verify $unit: nothing about the unit"

# --- the agent, as the service runs it ---------------------------------------
# run_as_service WHAT COMMAND...: the agent as the user sweepscan, with the
# installed configuration and key (a free port instead of 5600): proves
# both are readable and valid for that user; then SIGTERM must end it with 0.
run_as_service() {
  local what=$1
  shift
  setpriv --reuid=sweepscan --regid=sweepscan --init-groups --inh-caps=-all \
    "$@" --config /etc/sweepscan/robotd.conf --listen 127.0.0.1:0 \
    >"$work/robotd.out" 2>"$work/robotd.err" &
  robotd_pid=$!
  local port="" status=124
  for _ in $(seq 1 300); do
    port=$(sed -n 's/^listening on 127\.0\.0\.1:\([0-9][0-9]*\)$/\1/p' "$work/robotd.out")
    [ -n "$port" ] && break
    kill -0 "$robotd_pid" 2>/dev/null || break
    sleep 0.1
  done
  [ -n "$port" ] || { cat "$work/robotd.out" "$work/robotd.err"; fail "$what (user sweepscan) did not print 'listening on 127.0.0.1:PORT'"; }
  ok "$what as sweepscan with /etc/sweepscan/robotd.conf: listening on 127.0.0.1:$port"
  if (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null; then
    ok "$what: a TCP connection to 127.0.0.1:$port is accepted"
  else
    fail "$what: cannot connect to 127.0.0.1:$port"
  fi
  kill -TERM "$robotd_pid"
  for _ in $(seq 1 100); do
    if ! kill -0 "$robotd_pid" 2>/dev/null; then
      wait "$robotd_pid"
      status=$?
      break
    fi
    sleep 0.1
  done
  local done_pid=$robotd_pid
  robotd_pid=""
  [ "$status" -eq 0 ] || { cat "$work/robotd.err"; fail "$what (pid $done_pid) exited $status on SIGTERM, not 0"; }
  ok "$what stopped on SIGTERM with exit status 0"
}
run_as_service sweepscan-robotd sweepscan-robotd

# The unit's ExecStopPost, as the service user with the installed
# configuration: no motor board here, so exit 1 with the reason (the "-"
# of the unit's line makes that no failure of the service).
setpriv --reuid=sweepscan --regid=sweepscan --init-groups --inh-caps=-all \
  sweepscan-robotd --config /etc/sweepscan/robotd.conf --stop-motors >"$work/stop.out" 2>"$work/stop.err"
rc=$?
if [ "$rc" -eq 1 ] && grep -q -- "--stop-motors" "$work/stop.err"; then
  ok "sweepscan-robotd --stop-motors without a board: exit 1, $(head -n1 "$work/stop.err")"
else
  cat "$work/stop.out" "$work/stop.err"
  fail "sweepscan-robotd --stop-motors without a board exited $rc"
fi

# --- the arm64 package, from the outside (installed and run at the end) -------
if [ -n "$arm64_deb" ]; then
  a=$(dpkg-deb -f "$arm64_deb" Architecture)
  [ "$a" = arm64 ] || fail "$arm64_deb: Architecture $a"
  depends=$(dpkg-deb -f "$arm64_deb" Depends)
  grep -q "libqt5core5a" <<<"$depends" || fail "$arm64_deb: Depends lacks libqt5core5a: $depends"
  ok "$(basename "$arm64_deb"): Architecture arm64, Depends: $depends"
  # (Whole listings in variables: grep -q ending a pipe early would kill
  # dpkg-deb with SIGPIPE, a failure under pipefail.)
  contents=$(dpkg-deb -c "$arm64_deb")
  grep -q '\./usr/bin/sweepscan-robotd$' <<<"$contents" || fail "$arm64_deb lacks /usr/bin/sweepscan-robotd"
  mkdir "$work/arm64"
  dpkg-deb -x "$arm64_deb" "$work/arm64"
  what=$(file -b "$work/arm64/usr/bin/sweepscan-robotd")
  grep -q "ARM aarch64" <<<"$what" || fail "the arm64 package's sweepscan-robotd is: $what"
  ok "the arm64 package's /usr/bin/sweepscan-robotd: $(cut -d, -f1-2 <<<"$what")"
  list() { dpkg-deb -c "$1" | awk '{print $6}' | sort; }
  if ! diff <(list "$robotd_deb") <(list "$arm64_deb") >"$work/lists.diff"; then
    cat "$work/lists.diff"
    fail "the amd64 and arm64 sweepscan-robotd packages hold different files"
  fi
  ok "the amd64 and arm64 sweepscan-robotd packages hold the same files"
  control=$(dpkg-deb -I "$arm64_deb")
  grep -q " conffiles" <<<"$control" || fail "$arm64_deb has no conffiles"
  ok "the arm64 package has conffiles and maintainer scripts ($(grep -cE ' (postinst|prerm|postrm) ' <<<"$control") of 3)"
else
  echo "note: no $dist/sweepscan-robotd_*_arm64.deb: arm64 checks skipped"
fi

# --- the udev rules ----------------------------------------------------------
# udevadm test really applies a device's owner, mode and symlinks, so it runs
# in a private mount namespace on a tmpfs /dev (with a copy of one tty node)
# and a tmpfs /run: the real /dev and /run are not touched.
if command -v udevadm >/dev/null && command -v unshare >/dev/null; then
  rules=/lib/udev/rules.d/60-sweepscan.rules
  tty=$(scripts/udev-rules-test.sh "$rules" lidar "$work/udev-lidar.out") \
    || { cat "$work/udev-lidar.out"; fail "udevadm test (role lidar) failed"; }
  if grep -iE "60-sweepscan\.rules.*(invalid|error|fail|unknown|ignor)" "$work/udev-lidar.out"; then
    fail "udevadm test complains about 60-sweepscan.rules"
  fi
  grep -q "60-sweepscan.rules:[0-9]* LINK 'sweepscan/lidar'" "$work/udev-lidar.out" \
    || { cat "$work/udev-lidar.out"; fail "udevadm test: no symlink sweepscan/lidar from 60-sweepscan.rules"; }
  grep -q "^crw-rw---- .* root dialout " "$work/udev-lidar.out" \
    || { tail -n 3 "$work/udev-lidar.out"; fail "udevadm test: the device is not root:dialout 0660"; }
  ok "udev: a tty with SWEEPSCAN_DEVICE=lidar from an earlier rule gets /dev/sweepscan/lidar, root:dialout 0660 ($tty)"
  scripts/udev-rules-test.sh "$rules" none "$work/udev-none.out" >/dev/null \
    || { cat "$work/udev-none.out"; fail "udevadm test (role none) failed"; }
  if grep -q "LINK 'sweepscan/" "$work/udev-none.out"; then fail "udev: SWEEPSCAN_DEVICE=none still made a link"; fi
  scripts/udev-rules-test.sh "$rules" "" "$work/udev-plain.out" >/dev/null \
    || { cat "$work/udev-plain.out"; fail "udevadm test (no role) failed"; }
  if grep -q "LINK 'sweepscan/" "$work/udev-plain.out"; then fail "udev: a tty without a role got a sweepscan link"; fi
  ok "udev: no link for SWEEPSCAN_DEVICE=none, nor for a tty the table does not know"
else
  echo "note: udevadm or unshare missing: udev rules not tested"
fi

# --- remove, purge -----------------------------------------------------------
dpkg -L sweepscan sweepscan-robotd | sort -u >"$work/files"
[ -s "$work/files" ] || fail "dpkg -L listed nothing"
dpkg -r sweepscan sweepscan-robotd >"$work/remove.log" 2>&1 || { cat "$work/remove.log"; fail "dpkg -r"; }
[ ! -e /usr/bin/sweepscan-robotd ] || fail "/usr/bin/sweepscan-robotd is still there after dpkg -r"
if [ ! -f /etc/sweepscan/robotd.conf ] || [ ! -f "$key" ]; then
  fail "dpkg -r removed /etc/sweepscan/robotd.conf or the key (only purge should)"
fi
ok "dpkg -r sweepscan sweepscan-robotd: programs gone, /etc/sweepscan/robotd.conf and the key kept"
dpkg -P sweepscan sweepscan-robotd >"$work/purge.log" 2>&1 || { cat "$work/purge.log"; fail "dpkg -P"; }
left=0
while IFS= read -r path; do
  [ -e "$path" ] || [ -L "$path" ] || continue
  if [ -d "$path" ] && { dpkg-query -S "$path" >/dev/null 2>&1 || [ -n "$(ls -A "$path")" ]; }; then
    continue # shared with other packages, or holds their files
  fi
  echo "  left behind: $path"
  left=$((left + 1))
done <"$work/files"
[ "$left" -eq 0 ] || fail "$left installed paths are left after dpkg -P"
ok "dpkg -P: none of the $(wc -l <"$work/files") paths dpkg -L listed is left (but shared folders)"
[ ! -e /etc/sweepscan ] || fail "/etc/sweepscan is still there after purge: $(ls -A /etc/sweepscan)"
ok "/etc/sweepscan is gone after purge"
getent passwd sweepscan >/dev/null || fail "purge removed the user sweepscan (it should stay)"
ok "the user sweepscan stays after purge (Debian's recommendation)"

# --- the arm64 package, installed and run under emulation -------------------
# What the Raspberry Pi gets: with multiarch its arm64 dependencies install
# beside this machine's (scripts/build-arm64.sh put them there), and the
# aarch64 agent runs under qemu-aarch64-static (no binfmt needed), as the
# service user with the configuration and key its own postinst made.
if [ -n "$arm64_deb" ] && dpkg --print-foreign-architectures | grep -qx arm64 &&
  command -v qemu-aarch64-static >/dev/null; then
  apt-get install -y --no-install-recommends "./$arm64_deb" >"$work/apt-arm64.log" 2>&1 \
    || { tail -n 30 "$work/apt-arm64.log"; fail "apt-get install ./$arm64_deb"; }
  [ "$(dpkg-query -W -f='${Architecture}' sweepscan-robotd)" = arm64 ] || fail "sweepscan-robotd:arm64 is not what is installed"
  st=$(stat -c '%a %U:%G %s' "$key")
  [ "$st" = "400 sweepscan:sweepscan 32" ] || fail "arm64 postinst: $key is '$st'"
  ok "installed $(basename "$arm64_deb") with apt (multiarch): user, key and conffile made by its postinst"
  run_as_service "sweepscan-robotd (arm64, qemu)" qemu-aarch64-static -L / /usr/bin/sweepscan-robotd
  dpkg -P sweepscan-robotd >"$work/purge-arm64.log" 2>&1 || { cat "$work/purge-arm64.log"; fail "dpkg -P sweepscan-robotd:arm64"; }
  if [ -e /usr/bin/sweepscan-robotd ] || [ -e /etc/sweepscan ]; then
    fail "dpkg -P sweepscan-robotd:arm64 left files"
  fi
  ok "dpkg -P sweepscan-robotd (arm64): program and /etc/sweepscan gone"
else
  echo "note: the arm64 package was not installed (no arm64 deb, no arm64 architecture or no qemu-aarch64-static)"
fi

echo "package-smoke: all checks passed"
