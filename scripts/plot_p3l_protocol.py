#!/usr/bin/python3
"""Plots the P3L synthetic protocol (Choi et al. 2017, section 5.1, Fig. 4).

Docs-only tool (not run by CI); needs python3-matplotlib:
    build/app/sweepscan-cli p3l --protocol --trials 1000 --steps 10 --noise-max 0.1 \
        --csv docs/data/p3l_protocol.csv
    scripts/plot_p3l_protocol.py docs/data/p3l_protocol.csv docs/images/p3l_protocol.png
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: plot_p3l_protocol.py PROTOCOL.csv OUT.png")
    rows = list(csv.DictReader(open(sys.argv[1])))
    noise = [1000 * float(r["noise_width_m"]) for r in rows]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, key, unit, scale in ((axes[0], "rot", "deg", 1.0), (axes[1], "trans", "cm", 100.0)):
        suffix = "_deg" if key == "rot" else "_m"
        mean = [scale * float(r[key + "_mean" + suffix]) for r in rows]
        std = [scale * float(r[key + "_std" + suffix]) for r in rows]
        ax.errorbar(noise, mean, yerr=std, fmt="o-", capsize=3, label="mean +- std (nearest candidate)")
        if key + "_median" + suffix in rows[0]:
            med = [scale * float(r[key + "_median" + suffix]) for r in rows]
            ax.plot(noise, med, "s--", label="median")
        ranked = [scale * float(r["ranked_" + key + "_mean" + suffix]) for r in rows]
        ax.plot(noise, ranked, "^:", label="mean, ranked by a 4th line")
        ax.set_xlabel("uniform noise width (mm)")
        ax.set_ylabel(("rotation" if key == "rot" else "translation") + " error (" + unit + ")")
        ax.set_ylim(bottom=0)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    trials = rows[0]["trials"]
    fig.suptitle("P3L minimal solver, %s random trials per noise level (cf. Choi et al. 2017, Fig. 4)" % trials)
    fig.tight_layout()
    fig.savefig(sys.argv[2], dpi=110)


if __name__ == "__main__":
    main()
