#!/usr/bin/env python3
"""Plots of the closed-loop safety-gate run (test/ros/safety_gate_closed_loop.test run with
SSM_GATE_OUT=<dir>): per scenario the commanded, gated and actual speed over time and the distance
from the chair's footprint to the nearest hazard, and where the chair stopped.

    /usr/bin/python3 scripts/plot_gate.py <dir>      # reads <dir>/*.csv, writes <dir>/gate.png

Prints one line per scenario (the same numbers as the test's output)."""
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ORDER = ["curb", "stairs", "ramp14", "pole", "corridor", "ramp5"]
TITLES = {
    "curb": "15 cm curb drop",
    "stairs": "stair down",
    "ramp14": "14 deg ramp up",
    "pole": "pole 0.15 m wide",
    "corridor": "corridor (walls 0.5 m beside)",
    "ramp5": "5 deg ramp up",
}


def read(path):
    rows = []
    with open(path) as f:
        for r in csv.DictReader(f):
            rows.append(r)
    return rows


def main():
    if len(sys.argv) != 2:
        print(__doc__)
        return 2
    d = sys.argv[1]
    names = [n for n in ORDER if os.path.exists(os.path.join(d, n + ".csv"))]
    if not names:
        print("no scenario CSV in %s" % d)
        return 1
    fig, axes = plt.subplots(2, len(names), figsize=(3.3 * len(names), 6.0), squeeze=False)
    for k, n in enumerate(names):
        rows = read(os.path.join(d, n + ".csv"))
        t = [float(r["t"]) for r in rows]
        cmd = [float(r["v_commanded"]) for r in rows]
        gated = [float(r["v_gated"]) for r in rows]
        base = [float(r["v_base"]) for r in rows]
        clear = [float(r["clearance"]) for r in rows]
        x0 = float(rows[0]["x"])
        travelled = float(rows[-1]["x"]) - x0
        moving = [g for g, r in zip(gated, rows) if float(r["x"]) - x0 > 0.05]
        slowest = min(moving) if moving else float("nan")
        final = clear[-1] if clear and clear[-1] >= 0 else float("nan")
        ax = axes[0][k]
        ax.plot(t, cmd, "k--", lw=1, label="commanded")
        ax.plot(t, gated, "r-", lw=1.5, label="gated")
        ax.plot(t, base, "b:", lw=1.5, label="base")
        ax.set_ylim(-0.05, 1.15)
        ax.set_title(TITLES.get(n, n), fontsize=10)
        ax.set_xlabel("time [s]")
        if k == 0:
            ax.set_ylabel("speed [m/s]")
            ax.legend(fontsize=8, loc="lower right")
        ax = axes[1][k]
        if any(c >= 0 for c in clear):
            ax.plot(t, clear, "g-", lw=1.5, label="footprint to nearest hazard [m]")
            ax.axhline(0.0, color="r", lw=1)
        else:  # no hazard in the scene: how far it went, and how high (a ramp)
            ax.plot(t, [float(r["x"]) - x0 for r in rows], "g-", lw=1.5, label="travelled [m]")
            ax.plot(t, [float(r["z"]) for r in rows], "m-", lw=1.5, label="height [m]")
            ax.legend(fontsize=8, loc="upper left")
        ax.set_xlabel("time [s]")
        if k == 0:
            ax.set_ylabel("footprint to nearest hazard [m]")
        if n in ("corridor", "ramp5"):
            what = "drove %.2f m, slowest %.2f m/s" % (travelled, slowest)
        else:
            what = "stopped %.2f m before it" % final
            ax.annotate("stop: %.2f m" % final, (t[-1], final), textcoords="offset points",
                        xytext=(-60, 15), fontsize=8, arrowprops={"arrowstyle": "->"})
        ax.set_title(what, fontsize=9)
        print("%-9s %-30s travelled %5.2f m, footprint to hazard at the end %s, slowest gated "
              "speed once moving %.2f m/s" % (n, TITLES.get(n, n), travelled,
                                               "%.2f m" % final if not math.isnan(final) else "-",
                                               slowest))
    fig.suptitle("Velocity safety gate, closed loop (1 m/s commanded; real disparity, "
                 "safety-map and gate nodelets)", fontsize=11)
    fig.tight_layout()
    out = os.path.join(d, "gate.png")
    fig.savefig(out, dpi=110)
    print("plot: %s" % out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
