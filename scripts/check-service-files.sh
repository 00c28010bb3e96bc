#!/usr/bin/env bash
# Checks the packaging files without installing anything (docs/deployment.md):
#   - packaging/systemd/sweepscan-robotd.service: systemd-analyze verify, on a
#     copy whose ExecStart runs the built sweepscan-robotd (verify wants the
#     program to exist), and systemd-analyze security's exposure score
#   - packaging/robotd.conf: the built sweepscan-robotd accepts every key
#     (started with it on a free loopback port and a temporary key, stopped)
#   - packaging/sweepscan.desktop: desktop-file-validate
#   - packaging/icons/sweepscan.svg: renders (rsvg-convert)
#   - the maintainer scripts and these scripts: shellcheck
#   - packaging/udev/60-sweepscan.rules: udevadm test in a private mount
#     namespace (root only; skipped otherwise)
# A missing tool is reported and its check skipped; any problem found exits 1.
#   scripts/check-service-files.sh [BUILD_DIR]      (default build)
set -uo pipefail
cd "$(dirname "$0")/.." || exit 2
build_dir="${1:-build}"
robotd="$PWD/$build_dir/app/sweepscan-robotd"
[[ "$build_dir" = /* ]] && robotd="$build_dir/app/sweepscan-robotd"

problems=0
ok() { echo "ok: $*"; }
problem() {
  echo "FAIL: $*"
  problems=$((problems + 1))
}
skip() { echo "skipped: $*"; }

work=$(mktemp -d /tmp/sweepscan-check.XXXXXX)
chmod 0755 "$work"
pid=""
cleanup() {
  if [ -n "$pid" ]; then kill -KILL "$pid" 2>/dev/null; fi
  rm -rf "$work"
}
trap cleanup EXIT

# --- the unit ----------------------------------------------------------------
unit=packaging/systemd/sweepscan-robotd.service
if ! command -v systemd-analyze >/dev/null; then
  skip "systemd-analyze missing (apt install systemd)"
elif [ ! -x "$robotd" ]; then
  problem "$robotd is not built: systemd-analyze verify needs it"
else
  sed "s|^ExecStart=/usr/bin/sweepscan-robotd |ExecStart=$robotd |; s|^ExecStopPost=-/usr/bin/sweepscan-robotd |ExecStopPost=-$robotd |" \
    "$unit" >"$work/sweepscan-robotd.service"
  grep -q "^ExecStart=$robotd " "$work/sweepscan-robotd.service" || problem "$unit: no ExecStart=/usr/bin/sweepscan-robotd line"
  # --man=no: the man page of Documentation= is not installed yet.
  systemd-analyze verify --man=no "$work/sweepscan-robotd.service" >"$work/verify.out" 2>&1
  rc=$?
  if [ "$rc" -ne 0 ] || grep -qi "sweepscan" "$work/verify.out"; then
    cat "$work/verify.out"
    problem "systemd-analyze verify $unit (exit $rc)"
  else
    [ -s "$work/verify.out" ] && sed 's/^/  (not about sweepscan) /' "$work/verify.out"
    ok "systemd-analyze verify $unit"
  fi
  if systemd-analyze security --offline=yes "$work/sweepscan-robotd.service" >"$work/security.out" 2>&1; then
    ok "systemd-analyze security: $(grep -i "overall exposure" "$work/security.out" | sed 's/.*→ *//; s/^ *//')"
  else
    skip "systemd-analyze security --offline=yes (needs systemd >= 252): $(tail -n1 "$work/security.out")"
  fi
fi

# --- the configuration file ----------------------------------------------------
if [ -x "$robotd" ]; then
  head -c 32 /dev/urandom >"$work/key"
  chmod 0600 "$work/key"
  "$robotd" --config packaging/robotd.conf --listen 127.0.0.1:0 --key-file "$work/key" \
    >"$work/robotd.out" 2>"$work/robotd.err" &
  pid=$!
  for _ in $(seq 1 100); do
    grep -q "^listening on 127.0.0.1:" "$work/robotd.out" && break
    kill -0 "$pid" 2>/dev/null || break
    sleep 0.1
  done
  if grep -q "^listening on 127.0.0.1:" "$work/robotd.out"; then
    kill -TERM "$pid"
    wait "$pid"
    rc=$?
    pid=""
    if [ "$rc" -eq 0 ]; then
      ok "sweepscan-robotd accepts packaging/robotd.conf (and stops on SIGTERM with 0)"
    else
      problem "sweepscan-robotd with packaging/robotd.conf exited $rc on SIGTERM"
    fi
  else
    pid=""
    cat "$work/robotd.out" "$work/robotd.err"
    problem "sweepscan-robotd --config packaging/robotd.conf did not start"
  fi
else
  problem "$robotd is not built: packaging/robotd.conf not checked"
fi

# --- desktop entry and icon ---------------------------------------------------
if command -v desktop-file-validate >/dev/null; then
  if out=$(desktop-file-validate packaging/sweepscan.desktop 2>&1) && [ -z "$out" ]; then
    ok "desktop-file-validate packaging/sweepscan.desktop"
  else
    echo "$out"
    problem "desktop-file-validate packaging/sweepscan.desktop"
  fi
else
  skip "desktop-file-validate missing (apt install desktop-file-utils)"
fi
if command -v rsvg-convert >/dev/null; then
  if rsvg-convert -w 48 -h 48 packaging/icons/sweepscan.svg -o "$work/icon.png" 2>"$work/rsvg.err" \
    && [ -s "$work/icon.png" ] && [ ! -s "$work/rsvg.err" ]; then
    ok "packaging/icons/sweepscan.svg renders (rsvg-convert)"
  else
    cat "$work/rsvg.err"
    problem "packaging/icons/sweepscan.svg does not render"
  fi
else
  skip "rsvg-convert missing (apt install librsvg2-bin)"
fi

# --- shell scripts -------------------------------------------------------------
if command -v shellcheck >/dev/null; then
  if shellcheck -s sh packaging/debian/robotd/postinst packaging/debian/robotd/prerm \
    packaging/debian/robotd/postrm; then
    ok "shellcheck (POSIX sh): postinst prerm postrm"
  else
    problem "shellcheck: maintainer scripts"
  fi
  if shellcheck scripts/package.sh scripts/package-smoke.sh scripts/check-service-files.sh; then
    ok "shellcheck: scripts/package.sh package-smoke.sh check-service-files.sh"
  else
    problem "shellcheck: packaging scripts"
  fi
else
  skip "shellcheck missing (apt install shellcheck)"
fi
for s in postinst prerm postrm; do
  f=packaging/debian/robotd/$s
  if ! head -n1 "$f" | grep -qx '#!/bin/sh' || ! grep -qx 'set -e' "$f"; then
    problem "$f must start with #!/bin/sh and use set -e"
  fi
  sh -n "$f" || problem "$f: sh -n"
done

# --- udev rules ----------------------------------------------------------------
rules=packaging/udev/60-sweepscan.rules
if ! command -v udevadm >/dev/null || ! command -v unshare >/dev/null; then
  skip "udevadm or unshare missing: $rules not tested"
elif [ "$(id -u)" -ne 0 ]; then
  skip "$rules: udevadm test needs root (a private mount namespace)"
else
  if ! tty=$(scripts/udev-rules-test.sh "$rules" motor "$work/udev.out"); then
    cat "$work/udev.out"
    problem "udevadm test with $rules failed"
  elif grep -iE "60-sweepscan\.rules.*(invalid|error|fail|unknown|ignor)" "$work/udev.out"; then
    problem "udevadm complains about $rules"
  elif ! grep -q "60-sweepscan.rules:[0-9]* LINK 'sweepscan/motor'" "$work/udev.out"; then
    cat "$work/udev.out"
    problem "$rules: a tty with SWEEPSCAN_DEVICE=motor got no sweepscan/motor link"
  else
    ok "udevadm test: $rules reads cleanly and links sweepscan/motor ($tty)"
  fi
fi

if [ "$problems" -ne 0 ]; then
  echo "check-service-files: $problems problem(s)"
  exit 1
fi
echo "check-service-files: all checks passed"
