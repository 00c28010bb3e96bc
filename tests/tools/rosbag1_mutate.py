#!/usr/bin/env python3
"""Mutation campaign for the ROS 1 bag path as a whole (docs/fuzzing.md,
"The ROS 1 bag checks"): the libFuzzer target checks sweepscan's own checks,
this checks that what they accept rosbag_storage also survives. Each run
copies a seed bag, changes a few bytes (single bytes, or a u32 set to a
large or small value: lengths and offsets), and runs `sweepscan-cli import`
on it with an address-space limit; a signal, a timeout or the limit is a
finding. Deterministic for a seed.

  tests/tools/rosbag1_mutate.py CLI SEED_BAG... [--runs N] [--seed S] [--keep DIR]
"""
import argparse
import os
import random
import resource
import shutil
import subprocess
import sys
import tempfile


def mutate(data, rng):
    b = bytearray(data)
    for _ in range(rng.randint(1, 4)):
        at = rng.randrange(13, len(b))  # after the magic
        kind = rng.random()
        if kind < 0.5:
            b[at] = rng.randrange(256)
        elif at + 4 <= len(b):
            value = rng.choice([0xFFFFFFFF, 0x7FFFFFFF, 0xFF000000, 0x00F50000, 0, 1, rng.randrange(1 << 32)])
            b[at:at + 4] = value.to_bytes(4, "little")
    return bytes(b)


def limit():
    resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))  # a runaway allocation fails, not the machine


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("cli")
    ap.add_argument("seeds", nargs="+")
    ap.add_argument("--runs", type=int, default=300)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--keep", help="copy findings here")
    a = ap.parse_args()
    rng = random.Random(a.seed)
    work = tempfile.mkdtemp(prefix="rosbag1_mutate.")
    counts = {"ok": 0, "refused": 0, "finding": 0}
    try:
        for seed in a.seeds:
            data = open(seed, "rb").read()
            for run in range(a.runs):
                bag = os.path.join(work, "m.bag")
                open(bag, "wb").write(mutate(data, rng))
                out = os.path.join(work, "m.sweepscan")
                shutil.rmtree(out, ignore_errors=True)
                try:
                    p = subprocess.run([a.cli, "import", bag, "--out", out, "--mount", "0,0,0.3,0,0,0"],
                                       stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, timeout=60,
                                       preexec_fn=limit)
                    rc, err = p.returncode, p.stderr.decode(errors="replace")
                except subprocess.TimeoutExpired:
                    rc, err = "timeout", ""
                bad = rc == "timeout" or rc < 0 or "bad_alloc" in err
                if bad:
                    counts["finding"] += 1
                    print("finding: %s run %d: rc %s %s" % (seed, run, rc, err.strip()[-200:]))
                    if a.keep:
                        os.makedirs(a.keep, exist_ok=True)
                        shutil.copy(bag, os.path.join(a.keep, "%s_%d.bag" % (os.path.basename(seed), run)))
                elif rc == 0:
                    counts["ok"] += 1
                else:
                    counts["refused"] += 1
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print("mutations: %d imported, %d refused with a message, %d findings" %
          (counts["ok"], counts["refused"], counts["finding"]))
    return 1 if counts["finding"] else 0


if __name__ == "__main__":
    sys.exit(main())
