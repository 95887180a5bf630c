#!/usr/bin/python3
"""Tables of `scripts/bench --ros` from the probe's JSON files (ros_replay_probe.py).

    ros_replay_report.py --out-json ros.json --out-md ros.md --meta meta.json RUN.json...

Each RUN.json is one replay (one launch variant); meta.json holds what the shell knew (variant
names, launch arguments, load average, bag). Also the helper that turns config/disparity.yaml
into stereo_image_proc's disparity parameters (--sip-params), so that its nodelet runs the same
matcher as ours.
"""
import argparse
import json
import sys


def fmt(x, digits=1):
    if x is None:
        return "n/a"
    return ("%." + str(digits) + "f") % x


def sip_params(disparity_yaml):
    """stereo_image_proc/disparity parameters (its Disparity.cfg) for our matcher settings."""
    import yaml

    with open(disparity_yaml) as f:
        c = yaml.safe_load(f)
    return {
        "stereo_algorithm": 1 if c.get("matcher", "bm") == "sgbm" else 0,
        "prefilter_cap": int(c.get("pre_filter_cap", 31)),
        "correlation_window_size": int(c.get("block_size", 9)),
        "min_disparity": int(c.get("min_disparity", 0)),
        "disparity_range": int(c.get("num_disparities", 64)),
        "uniqueness_ratio": float(c.get("uniqueness_ratio", 15))
        if c.get("enable_uniqueness", True) else 0.0,
        "texture_threshold": int(c.get("bm_texture_threshold", 0)),
        "speckle_size": int(c.get("speckle_window_size", 0)),
        "speckle_range": int(c.get("speckle_range", 1)),
        # Its minimum: 0 turns on OpenCV's one-pass left-right check (ours is off: -1).
        "disp12MaxDiff": 0,
    }


def disparity_drops(run):
    for name, d in run.get("diagnostics", {}).items():
        if name.endswith(": disparity"):
            v = d["values"].get("frames dropped (input faster than processing)")
            return v if v is not None else "n/a"
    return "n/a"


def delay_row(name, run, meta):
    w = run.get("window", {})
    d = (run.get("outputs", {}).get(meta.get("map_topic", "/safety_map")) or {}).get("delay_ms")
    c = run.get("safety_map_counters", {})
    cpu = run.get("manager_cpu", {})
    rss = run.get("manager_rss_mb", {})
    return "| %s | %s | %s | %d / %d | %s | %s | %s / %s | %s | %s | %s | %s | %s |" % (
        name, meta.get("cores", "2 (shared)"), fmt(w.get("input_rate_hz")),
        run.get("maps", 0), w.get("images", 0), c.get("stationary", "n/a"),
        run.get("frames_lost", "n/a"), disparity_drops(run), c.get("dropped", "n/a"),
        fmt(d and d.get("median")), fmt(d and d.get("p95")), fmt(d and d.get("max")),
        fmt(cpu.get("cores_used"), 2),
        "%s -> %s" % (fmt(rss.get("at_first_image"), 0), fmt(rss.get("at_window_end"), 0))
        if rss else "n/a")


def report(runs, metas, overall):
    out = []
    out.append("### ROS replay (`scripts/bench --ros`)\n")
    out.append("Bag `%s` played by `launch/bag_replay.launch` at rate %s, "
               "load average %s at start, %s at end on %s cores. Delay: wall time from the left "
               "image's arrival to the arrival of the safety map with its stamp, both taken by "
               "the measuring node (`scripts/lib/ros_replay_probe.py`); window: first image to "
               "%s s (bag time) before the last.\n" % (
                   overall.get("bag"), overall.get("rate"),
                   overall.get("load_start"), overall.get("load_end"), overall.get("nproc"),
                   overall.get("tail")))
    out.append("| variant | manager on | input [Hz] | maps / images | stationary (no map by "
               "design) | frames lost | of which dropped by disparity / safety map | delay "
               "median [ms] | delay p95 [ms] | delay max [ms] | manager CPU [cores] | manager RSS "
               "first image -> end [MB] |")
    out.append("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for run, meta in zip(runs, metas):
        out.append(delay_row(meta["name"], run, meta))
    out.append("")
    out.append("Per nodelet, from its diagnostics at the end of the window (counters since start; "
               "their timer runs on the bag's clock) and the safety map's StageTimings:\n")
    out.append("| variant | nodelet | received | processed | dropped | processing [ms] |")
    out.append("|---|---|---|---|---|---|")
    for run, meta in zip(runs, metas):
        for name, d in sorted(run.get("diagnostics", {}).items()):
            v = d["values"]
            dropped = [x for k, x in v.items() if k.startswith("frames dropped")]
            proc = v.get("processing time, mean [ms]") or v.get("disparity time, last frame [ms]")
            out.append("| %s | %s | %s | %s | %s | %s |" % (
                meta["name"], name, v.get("frames received", "n/a"),
                v.get("frames processed", "n/a"), " + ".join(dropped) if dropped else "n/a",
                (proc + " (mean)") if proc else "n/a"))
    out.append("")
    out.append("Other outputs (same delay definition):\n")
    out.append("| variant | topic | messages | delay median [ms] | delay p95 [ms] |")
    out.append("|---|---|---|---|---|")
    for run, meta in zip(runs, metas):
        for topic, o in sorted(run.get("outputs", {}).items()):
            if topic == meta.get("map_topic", "/safety_map"):
                continue
            d = o.get("delay_ms")
            out.append("| %s | %s | %d | %s | %s |" % (meta["name"], topic, o.get("messages", 0),
                                                     fmt(d and d.get("median")),
                                                     fmt(d and d.get("p95"))))
    out.append("")
    out.append("Launch arguments per variant:\n")
    for meta in metas:
        out.append("- %s: `%s`%s" % (meta["name"], " ".join(meta.get("args", [])) or "(defaults)",
                                     (" + stereo_image_proc parameters `%s`" % json.dumps(
                                         meta["sip_params"], sort_keys=True))
                                     if meta.get("sip_params") else ""))
    return "\n".join(out) + "\n"


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--sip-params", metavar="DISPARITY_YAML",
                   help="print stereo_image_proc's parameters for this config as YAML and exit")
    p.add_argument("--meta", help="JSON list of per-run metadata + overall")
    p.add_argument("--out-json")
    p.add_argument("--out-md")
    p.add_argument("runs", nargs="*")
    a = p.parse_args()
    if a.sip_params:
        for k, v in sorted(sip_params(a.sip_params).items()):
            print("%s: %s" % (k, v))
        return 0
    with open(a.meta) as f:
        meta = json.load(f)
    runs = []
    for r in a.runs:
        try:
            with open(r) as f:
                runs.append(json.load(f))
        except (OSError, ValueError) as e:
            runs.append({"error": "no result: %s" % e})
    metas = meta["runs"]
    md = report(runs, metas, meta["overall"])
    if a.out_json:
        with open(a.out_json, "w") as f:
            json.dump({"overall": meta["overall"],
                       "runs": [dict(m, result=r) for m, r in zip(metas, runs)]}, f, indent=1)
    if a.out_md:
        with open(a.out_md, "w") as f:
            f.write(md)
    sys.stdout.write(md)
    ok = all(r.get("maps", 0) > 0 for r in runs)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
