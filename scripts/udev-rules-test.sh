#!/bin/sh
# Runs `udevadm test` of sweepscan's udev rules on a real tty of this machine
# as if an earlier rule (like /etc/udev/rules.d/60-sweepscan-local.rules) had
# given it the role ROLE, and writes udevadm's output and the device node's
# `ls -l` to OUT. udevadm test applies owner, mode and symlinks for real, so
# it runs in a private mount namespace on a tmpfs /dev (holding a copy of the
# tty's node) and a tmpfs /run: the machine's /dev and /run are not touched.
# Needs root and unshare. Used by check-service-files.sh and package-smoke.sh.
#   scripts/udev-rules-test.sh RULES ROLE OUT     (ROLE "" = no role)
# Prints the tty it used; exit 1 if there is none or udevadm fails.
set -eu
rules=$1 role=$2 out=$3
tty=""
for d in ttyS0 ttyS1 console tty ptmx; do
  if [ -r "/sys/class/tty/$d/dev" ]; then
    tty=$d
    break
  fi
done
if [ -z "$tty" ]; then
  echo "udev-rules-test: no tty device under /sys/class/tty" >&2
  exit 1
fi
unshare --mount --propagation private sh -eu -c '
  tty=$1 role=$2 rules=$3 out=$4
  mm=$(cat "/sys/class/tty/$tty/dev")
  mount -t tmpfs -o mode=0755 sweepscan-udev-dev /dev
  mount -t tmpfs -o mode=0755 sweepscan-udev-run /run
  mkdir -p /run/udev/rules.d
  mknod -m 0600 "/dev/$tty" c "${mm%%:*}" "${mm##*:}"
  cp "$rules" /run/udev/rules.d/60-sweepscan.rules
  if [ -n "$role" ]; then
    # Sorts before 60-sweepscan.rules, as 60-sweepscan-local.rules does.
    printf "SUBSYSTEM==\"tty\", KERNEL==\"%s\", ENV{SWEEPSCAN_DEVICE}=\"%s\"\n" "$tty" "$role" \
      > /run/udev/rules.d/60-sweepscan-0test.rules
  fi
  udevadm test --action=add "/sys/class/tty/$tty" > "$out" 2>&1
  ls -l "/dev/$tty" >> "$out"
' sh "$tty" "$role" "$rules" "$out"
echo "$tty"
