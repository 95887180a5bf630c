#!/usr/bin/python3
"""Figures of the evaluation (paper 000 Sec. VII) from the evaluator's metrics.json.

    scripts/plot_evaluation.py OUT/metrics.json [--out DIR]

Writes next to metrics.json (or into DIR):
  fig6a_roc.png      ROC of 000 Fig. 6(a): mean TP rate against mean FP rate over the datasets,
                     one point per decr value with its standard deviations, and the paper's
                     Table II values for comparison.
  fig6b_latency.png  Frame latency of 000 Fig. 6(b): frames until 50 % and 90 % of the board's
                     width is occupied, against the board's initial distance, textured and
                     untextured (decr = 1). When a threshold is never reached the number of frames
                     the board was seen is plotted with an open marker, as the paper plots the
                     maximum value for that case.
  rates_per_dataset.png  FN and FP rate of every dataset for each decr value.
Uses Debian's python3-matplotlib (run with /usr/bin/python3).
"""
import argparse
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

# 000 Table II: decr -> (FP mean, FP std, TP mean, TP std) in percent.
PAPER_TABLE2 = {1: (9.3, 4.7, 97.0, 1.8), 3: (6.2, 3.7, 91.5, 5.3), 5: (5.2, 2.4, 88.8, 7.3)}


def finite(x):
    return x is not None and isinstance(x, (int, float)) and math.isfinite(x)


def plot_roc(metrics, path):
    runs = [r for r in metrics["runs"] if r["summary"]["datasets"] > 0 and r["decr"] >= 0]
    if not runs:
        return False
    fig, ax = plt.subplots(figsize=(5.5, 4.5))
    xs, ys = [], []
    for r in sorted(runs, key=lambda r: r["decr"]):
        s = r["summary"]
        fp, tp = s["fp"], s["tp"]
        if not (finite(fp["mean"]) and finite(tp["mean"])):
            continue
        x, y = 100 * fp["mean"], 100 * tp["mean"]
        xs.append(x)
        ys.append(y)
        ax.errorbar(x, y, xerr=100 * (fp["std"] or 0), yerr=100 * (tp["std"] or 0), fmt="o",
                    color="tab:blue", capsize=3)
        ax.annotate("decr %d" % r["decr"], (x, y), textcoords="offset points", xytext=(6, -12))
    ax.plot(xs, ys, "-", color="tab:blue", label="this package (synthetic datasets)")
    px = [PAPER_TABLE2[d][0] for d in (1, 3, 5)]
    py = [PAPER_TABLE2[d][2] for d in (1, 3, 5)]
    ax.plot(px, py, "s--", color="0.5", label="paper 000, Table II")
    for d, x, y in zip((1, 3, 5), px, py):
        ax.annotate("%d" % d, (x, y), textcoords="offset points", xytext=(5, 3), color="0.4")
    ax.set_xlabel("false positive rate [%]")
    ax.set_ylabel("true positive rate [%]")
    ax.set_title("ROC for the decrement parameter (000 Fig. 6(a))")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return True


def latency_points(metrics):
    """(textured, distance, to50, to90, available) of the decr = 1 run (else the first)."""
    runs = metrics["runs"]
    run = next((r for r in runs if r["decr"] == 1), runs[0] if runs else None)
    pts = []
    if run is None:
        return pts
    for d in run["datasets"]:
        for l in d["latency"]:
            if not finite(l["start_distance_m"]):
                continue
            pts.append((l["textured"], l["start_distance_m"], l["frames_to_50"], l["frames_to_90"],
                        l["frames_available"]))
    return sorted(pts, key=lambda p: (p[0], p[1]))


def plot_latency(metrics, path):
    pts = latency_points(metrics)
    if not pts:
        return False
    fig, ax = plt.subplots(figsize=(5.5, 4.5))
    styles = {(True, 50): ("o-", "tab:blue", "Tex 50%"), (True, 90): ("s-", "tab:blue", "Tex 90%"),
              (False, 50): ("o--", "tab:red", "Untex 50%"),
              (False, 90): ("s--", "tab:red", "Untex 90%")}
    for textured in (True, False):
        for n, idx in ((50, 2), (90, 3)):
            sel = [p for p in pts if p[0] == textured]
            if not sel:
                continue
            fmt, colour, label = styles[(textured, n)]
            xs = [p[1] for p in sel]
            ys = [p[idx] if p[idx] > 0 else p[4] for p in sel]
            ax.plot(xs, ys, fmt, color=colour, label=label, markerfacecolor=colour)
            for p, y in zip(sel, ys):
                if p[idx] <= 0:  # never reached: the frames it was seen, open marker
                    ax.plot(p[1], y, fmt[0], color=colour, markerfacecolor="white", markersize=9)
    ax.set_xlabel("initial distance to the board [m]")
    ax.set_ylabel("frame latency [frames]")
    ax.set_title("Frame latency (000 Fig. 6(b)); open: not reached")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return True


def plot_per_dataset(metrics, path):
    runs = [r for r in metrics["runs"] if r["summary"]["datasets"] > 0]
    if not runs:
        return False
    names = [d["name"] for d in runs[0]["datasets"] if not d["latency_only"]]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    width = 0.8 / len(runs)
    for k, r in enumerate(runs):
        ds = {d["name"]: d for d in r["datasets"]}
        for ax, key in zip(axes, ("fn", "fp")):
            vals = [100 * ds[n]["rates"][key] if finite(ds[n]["rates"][key]) else 0 for n in names]
            ax.bar([i + k * width for i in range(len(names))], vals, width, label=r["label"])
    for ax, key in zip(axes, ("FN", "FP")):
        ax.set_xticks([i + 0.4 - width / 2 for i in range(len(names))])
        ax.set_xticklabels([n.split("_")[0] for n in names], rotation=0)
        ax.set_ylabel("%s rate [%%]" % key)
        ax.grid(True, axis="y", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Error rates per dataset (000 Sec. VII-A)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("metrics", help="metrics.json written by evaluate_safety_map")
    ap.add_argument("--out", help="output folder (default: the folder of metrics.json)")
    args = ap.parse_args()
    with open(args.metrics) as f:
        metrics = json.load(f)
    out = args.out or os.path.dirname(os.path.abspath(args.metrics))
    os.makedirs(out, exist_ok=True)
    made = []
    for name, fn in (("fig6a_roc.png", plot_roc), ("fig6b_latency.png", plot_latency),
                     ("rates_per_dataset.png", plot_per_dataset)):
        if fn(metrics, os.path.join(out, name)):
            made.append(os.path.join(out, name))
    for m in made:
        print("wrote %s" % m)
    return 0 if made else 1


if __name__ == "__main__":
    sys.exit(main())
