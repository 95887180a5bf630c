#!/usr/bin/python3
"""Watches a looping bag replay for scripts/soak (run with Debian's /usr/bin/python3).

Counts, from the ROS graph: simulated time played (the positive steps of /clock), the restarts
(the clock going back), the maps published, the map resets and warnings of the safety-map
nodelet, ERROR / FATAL messages on /rosout; samples the nodelet manager's resident memory
(/proc/<pid>/status VmRSS). Writes one CSV row per sample and, at the end, a JSON summary.
Stops once `--sim-minutes` of simulated time have been played, or when the manager dies.
"""
import argparse
import json
import os
import sys
import time

import rospy
from diagnostic_msgs.msg import DiagnosticArray
from rosgraph_msgs.msg import Clock, Log


class Monitor:
    def __init__(self, node):
        self.node = node.lstrip("/")
        self.last_clock = None
        self.sim_played = 0.0
        self.restarts = 0
        self.maps = 0
        self.maps_since_restart = 0
        self.maps_per_loop = []
        self.reset_warnings = 0
        self.errors = []
        self.diag = {}
        self.diag_time = None

    def on_clock(self, msg):
        t = msg.clock.to_sec()
        if self.last_clock is not None:
            if t >= self.last_clock:
                self.sim_played += t - self.last_clock
            elif self.last_clock - t > 1.0:
                self.restarts += 1
                self.maps_per_loop.append(self.maps_since_restart)
                self.maps_since_restart = 0
        self.last_clock = t

    def on_map(self, _msg):
        self.maps += 1
        self.maps_since_restart += 1

    def on_rosout(self, msg):
        if "resetting the map" in msg.msg:
            self.reset_warnings += 1
        if msg.level >= Log.ERROR:
            self.errors.append("%s: %s" % (msg.name, msg.msg))

    def on_diagnostics(self, msg):
        for s in msg.status:
            if s.name.startswith(self.node + ":") and "safety map" in s.name:
                self.diag = {kv.key: kv.value for kv in s.values}
                self.diag["summary"] = s.message
                self.diag["level"] = int.from_bytes(s.level, "little") if isinstance(
                    s.level, bytes) else int(s.level)


def rss_mb(pid):
    try:
        with open("/proc/%d/status" % pid) as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        return None
    return None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--pid", type=int, required=True, help="nodelet manager's pid")
    ap.add_argument("--node", default="/safety_map", help="safety-map nodelet name")
    ap.add_argument("--sim-minutes", type=float, default=30.0)
    ap.add_argument("--period", type=float, default=10.0, help="wall seconds between samples")
    ap.add_argument("--csv", required=True)
    ap.add_argument("--summary", required=True)
    a = ap.parse_args(rospy.myargv()[1:])

    rospy.init_node("soak_monitor", disable_signals=True)
    m = Monitor(a.node)
    rospy.Subscriber("/clock", Clock, m.on_clock, queue_size=100)
    rospy.Subscriber("/safety_map_labels", rospy.AnyMsg, m.on_map, queue_size=10)
    rospy.Subscriber("/rosout_agg", Log, m.on_rosout, queue_size=1000)
    rospy.Subscriber("/diagnostics", DiagnosticArray, m.on_diagnostics, queue_size=50)

    start = time.monotonic()
    samples = []
    alive = True
    with open(a.csv, "w") as csv:
        csv.write("wall_s,sim_played_s,restarts,rss_mb,maps,map_resets,frames_received,"
                  "frames_processed,frames_dropped,frames_rejected\n")
        while True:
            time.sleep(a.period)
            rss = rss_mb(a.pid)
            if rss is None:
                alive = False
                break
            d = m.diag
            row = [time.monotonic() - start, m.sim_played, m.restarts, rss, m.maps,
                   d.get("map resets", ""), d.get("frames received", ""),
                   d.get("frames processed", ""),
                   d.get("frames dropped (processing slower than input)", ""),
                   d.get("frames rejected (bad input)", "")]
            samples.append(row)
            csv.write(",".join("%.1f" % v if isinstance(v, float) else str(v) for v in row) + "\n")
            csv.flush()
            print("[soak] %6.0f s wall, %6.0f s simulated, %3d restarts, RSS %7.1f MB, %6d maps"
                  % (row[0], row[1], row[2], row[3], row[4]), flush=True)
            if m.sim_played >= 60.0 * a.sim_minutes:
                break

    # Memory: flat when the last quarter of the run holds no more than the second loop did
    # (the first loop fills the caches and the voxel grid's point lists), with 10 % slack.
    rss = [r[3] for r in samples]
    quarter = rss[-max(1, len(rss) // 4):]
    warm = [r[3] for r in samples if r[2] == 1] or rss[len(rss) // 4:len(rss) // 2] or rss
    summary = {
        "manager_alive": alive,
        "wall_seconds": round(time.monotonic() - start, 1),
        "simulated_seconds": round(m.sim_played, 1),
        "restarts": m.restarts,
        "maps_published": m.maps,
        "maps_per_loop_min": min(m.maps_per_loop[1:]) if len(m.maps_per_loop) > 1 else None,
        "reset_warnings": m.reset_warnings,
        "map_resets_diagnostics": m.diag.get("map resets"),
        "rss_mb_first": rss[0] if rss else None,
        "rss_mb_second_loop_max": max(warm) if warm else None,
        "rss_mb_last_quarter_max": max(quarter) if quarter else None,
        "rss_mb_max": max(rss) if rss else None,
        "errors_on_rosout": m.errors[:20],
        "last_diagnostics": m.diag,
    }
    problems = []
    if not alive:
        problems.append("the nodelet manager died")
    if m.sim_played < 60.0 * a.sim_minutes:
        problems.append("only %.0f s simulated" % m.sim_played)
    if warm and quarter and max(quarter) > 1.10 * max(warm):
        problems.append("memory grew: %.1f MB in the last quarter, %.1f MB in loop 2"
                        % (max(quarter), max(warm)))
    # Every restart resets the map once, with one warning (the last restart may still be
    # on its way through the pipeline when the run stops).
    resets = int(m.diag.get("map resets", "-1") or -1)
    if not (m.restarts - 1 <= resets <= m.restarts):
        problems.append("%d map resets for %d restarts" % (resets, m.restarts))
    if not (m.restarts - 1 <= m.reset_warnings <= m.restarts):
        problems.append("%d reset warnings for %d restarts" % (m.reset_warnings, m.restarts))
    if m.errors:
        problems.append("%d ERROR messages on /rosout" % len(m.errors))
    summary["problems"] = problems
    with open(a.summary, "w") as f:
        json.dump(summary, f, indent=2)
    print(json.dumps(summary, indent=2))
    rospy.signal_shutdown("done")
    return 0 if not problems else 1


if __name__ == "__main__":
    sys.exit(main())
