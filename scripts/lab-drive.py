#!/usr/bin/env python3
"""Writes a back-and-forth drive along the lab as a scenario (the long
sessions of scripts/gui-bench.sh and scripts/cli-memory.sh): 35 s straight
at 0.2 m/s, a half turn in place, back, a half turn; repeated to SECONDS.

Usage: scripts/lab-drive.py SECONDS OUT.json   (from the repository root)
"""
import json
import math
import sys

seconds, out = float(sys.argv[1]), sys.argv[2]
d = json.load(open("resources/scenarios/lab.json"))
turn = {"v_mps": 0.0, "w_radps": 0.3, "duration_s": math.pi / 0.3}
leg = {"v_mps": 0.2, "w_radps": 0.0, "duration_s": 35.0}
segs, t = [], 0.0
while t < seconds:
    segs += [leg, turn]
    t += leg["duration_s"] + turn["duration_s"]
d["path"]["segments"] = segs
d["name"] = "lab back and forth %.0f s" % seconds
json.dump(d, open(out, "w"), indent=1)
