#!/usr/bin/python3
"""Figure of the benchmark (scripts/bench) from bench_pipeline's JSON.

    scripts/plot_bench.py out/bench/bench.json [--out out/bench/bench.png]

Four panels:
  (a) ours against each peer, stage by stage: thread-CPU median per call (bar), its min..max
      (whisker) and the wall median (dot), log scale;
  (b) whole pipeline per frame against image size (320x240, 640x480, 1280x960);
  (c) mapper per frame against map size (5, 10, 20 m), on the dense SGBM points;
  (d) mapper per frame against voxel size (0.05, 0.1, 0.2 m), on the dense SGBM points.
Scaling panels: wall medians of the stages (solid) and the thread CPU of the whole call (dashed).
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

# (group title, [stage ids]) in the order of panel (a); missing stages are skipped.
COMPARISON_GROUPS = [
    ("disparity BM", ["disp.ours_bm", "disp.ours_bm_parallel", "disp.ours_bm_nofilters",
                      "disp.opencv_bm", "disp.sip_bm",
                      "disp.sip_bm_own_filters"]),
    ("disparity SGBM", ["disp.ours_sgbm", "disp.opencv_sgbm", "disp.sip_sgbm"]),
    ("reprojection", ["reproject.ours", "reproject.image_geometry"]),
    ("voxel update, pipeline points", ["voxel.ours", "voxel.octomap_discretize", "voxel.octomap"]),
    ("voxel update, dense points", ["voxel_dense.ours", "voxel_dense.octomap_discretize",
                                    "voxel_dense.octomap"]),
    ("plane fit, largest segment", ["planefit_dense.ours_segment", "planefit_dense.ours_points",
                                    "planefit_dense.pcl_sac"]),
    ("seg + fit + label", ["map_dense.seg_fit_label", "map.seg_fit_label"]),
]

# Stages whose bar is the wall time (they use a second thread).
WALL_BARS = {"disp.ours_bm_parallel"}

SHORT = {
    "disp.ours_bm": "ours BM + filters",
    "disp.ours_bm_parallel": "ours BM + filters, 2 threads (bar: wall)",
    "disp.ours_bm_nofilters": "ours BM, no filters",
    "disp.opencv_bm": "OpenCV StereoBM",
    "disp.sip_bm": "stereo_image_proc BM",
    "disp.sip_bm_own_filters": "stereo_image_proc BM + its filters",
    "disp.ours_sgbm": "ours SGBM + filters",
    "disp.opencv_sgbm": "OpenCV StereoSGBM",
    "disp.sip_sgbm": "stereo_image_proc SGBM",
    "reproject.ours": "ours reprojectDisparity",
    "reproject.image_geometry": "image_geometry projectDisparityImageTo3d",
    "voxel.ours": "ours VoxelGrid::integrate",
    "voxel.octomap_discretize": "OctoMap insertPointCloud (discretize)",
    "voxel.octomap": "OctoMap insertPointCloud",
    "voxel_dense.ours": "ours VoxelGrid::integrate",
    "voxel_dense.octomap_discretize": "OctoMap insertPointCloud (discretize)",
    "voxel_dense.octomap": "OctoMap insertPointCloud",
    "planefit_dense.ours_segment": "ours fitSegment",
    "planefit_dense.ours_points": "ours fitPlane (points gathered)",
    "planefit_dense.pcl_sac": "PCL SACSegmentation RANSAC",
    "map_dense.seg_fit_label": "ours, dense map",
    "map.seg_fit_label": "ours, pipeline map",
}

SCALING_STAGES = {
    "image_size": ["disparity", "reproject", "integrate", "seg_fit_label", "total"],
    "map_size": ["integrate", "height_map", "seg_fit_label", "total"],
    "voxel_size": ["integrate", "height_map", "seg_fit_label", "total"],
}


def finite(x):
    return isinstance(x, (int, float)) and math.isfinite(x)


def positive(x):
    return finite(x) and x > 0


def stat(stage, clock, key):
    s = stage.get(clock)
    return s.get(key) if isinstance(s, dict) else None


def plot_comparisons(ax, stages):
    by_id = {s["id"]: s for s in stages}
    labels, ys, colours = [], [], []
    y = 0
    group_ticks = []
    for title, ids in COMPARISON_GROUPS:
        present = [i for i in ids if i in by_id and stat(by_id[i], "wall_ms", "median") is not None]
        if not present:
            continue
        group_ticks.append((y, title))
        for i in present:
            s = by_id[i]
            # Work on a second thread is not in the measuring thread's CPU time: wall bars.
            key = "wall_ms" if i in WALL_BARS else "cpu_ms"
            cpu_med = stat(s, key, "median")
            cpu_min = stat(s, key, "min")
            cpu_max = stat(s, key, "max")
            wall_med = stat(s, "wall_ms", "median")
            colour = "tab:blue" if s.get("impl") == "ours" else "tab:orange"
            if positive(cpu_med):
                lo = cpu_med - cpu_min if positive(cpu_min) else 0
                hi = cpu_max - cpu_med if finite(cpu_max) else 0
                ax.barh(y, cpu_med, color=colour, alpha=0.8, xerr=[[lo], [hi]],
                        error_kw={"elinewidth": 0.8, "capsize": 2})
            if positive(wall_med):
                ax.plot(wall_med, y, "k.", markersize=5)
            labels.append(SHORT.get(i, i))
            ys.append(y)
            colours.append(colour)
            y += 1
        y += 0.8
    ax.set_yticks(ys)
    ax.set_yticklabels(labels, fontsize=7)
    for tick, c in zip(ax.get_yticklabels(), colours):
        tick.set_color("tab:blue" if c == "tab:blue" else "black")
    for gy, title in group_ticks:
        ax.annotate(title, xy=(1.0, gy - 0.55), xycoords=("axes fraction", "data"), ha="right",
                    va="bottom", fontsize=7, style="italic", color="dimgray")
    ax.invert_yaxis()
    ax.set_xscale("log")
    ax.set_xlabel("ms per call (bar: thread CPU median, whisker min..max; dot: wall median)")
    ax.set_title("(a) ours (blue) vs peers (orange), same input", fontsize=9)
    ax.grid(axis="x", which="both", alpha=0.3)


def plot_scaling(ax, points, sweep, title, xlabel, xfmt):
    pts = sorted([p for p in points if p["sweep"] == sweep and not p.get("error")],
                 key=lambda p: p["x"])
    if not pts:
        ax.set_visible(False)
        return
    xs = [p["x"] for p in pts]
    for stage in SCALING_STAGES[sweep]:
        vals = [p["wall_median_ms"].get(stage) for p in pts]
        if not any(positive(v) for v in vals):
            continue
        vx = [x for x, v in zip(xs, vals) if positive(v)]
        vy = [v for v in vals if positive(v)]
        ax.plot(vx, vy, "o-", label=stage.replace("_", " "), markersize=3)
    cpu = [p.get("cpu_total_median_ms") for p in pts]
    if any(positive(v) for v in cpu):
        ax.plot([x for x, v in zip(xs, cpu) if positive(v)], [v for v in cpu if positive(v)],
                "k--", label="CPU, whole call", linewidth=1)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xticks(xs)
    ax.set_xticklabels([xfmt(p) for p in pts], fontsize=7)
    ax.minorticks_off()
    ax.set_xlabel(xlabel, fontsize=8)
    ax.set_ylabel("ms per frame (median)", fontsize=8)
    ax.set_title(title, fontsize=9)
    ax.grid(which="both", alpha=0.3)
    ax.legend(fontsize=6)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("json")
    ap.add_argument("--out", help="PNG path (default: bench.png next to the JSON)")
    args = ap.parse_args()
    with open(args.json) as f:
        d = json.load(f)
    out = args.out or os.path.join(os.path.dirname(os.path.abspath(args.json)), "bench.png")

    fig = plt.figure(figsize=(13, 9))
    gs = fig.add_gridspec(3, 2, width_ratios=[1.35, 1])
    ax_a = fig.add_subplot(gs[:, 0])
    plot_comparisons(ax_a, d.get("stages", []))
    scaling = d.get("scaling", [])
    plot_scaling(fig.add_subplot(gs[0, 1]), scaling, "image_size",
                 "(b) whole pipeline vs image size", "image size",
                 lambda p: p["label"].split(",")[0])
    plot_scaling(fig.add_subplot(gs[1, 1]), scaling, "map_size",
                 "(c) mapper vs map size (dense SGBM points)", "map side [m] (height 3 m)",
                 lambda p: "%g" % p["x"])
    plot_scaling(fig.add_subplot(gs[2, 1]), scaling, "voxel_size",
                 "(d) mapper vs voxel size (dense SGBM points)", "voxel size l_v [m]",
                 lambda p: "%g" % p["x"])
    m, inp = d.get("machine", {}), d.get("input", {})
    fig.suptitle(
        "bench_pipeline%s: %s, %s measured frames at %sx%s; %s, load %s -> %s; pinned core %s"
        % (" --quick" if d.get("quick") else "", inp.get("scene", "?"),
           inp.get("measured_frames", "?"), inp.get("width", "?"), inp.get("height", "?"),
           m.get("cpu_model", "?"), " ".join(str(m.get("loadavg_start", "?")).split()[:3]),
           " ".join(str(m.get("loadavg_end", "?")).split()[:3]), m.get("pinned_cpu", "?")),
        fontsize=9)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    fig.savefig(out, dpi=110)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
