#!/usr/bin/python3
"""Measuring node of `scripts/bench --ros`: delay from each stereo image to the safety map made
from it, frames lost on the way, and the nodelet manager's CPU time and resident memory, while
launch/bag_replay.launch replays a dataset bag.

    ros_replay_probe.py --out FILE.json [--manager /safety_map_manager] [--cpu C] [--tail S] ...

Why wall clocks. Under /use_sim_time the stamps and every node's ros::Time come from the bag's
/clock, which rosbag play publishes at its own rate (100 Hz) and which runs `rate` times faster
than the wall clock: stamp-vs-clock differences are quantised and scaled, and say nothing about
the time the computer spent. So this node takes, with one monotonic wall clock, the time it
receives each left image (the moment rosbag play publishes it: in a live system the image stamp
is that moment, up to the driver) and the time it receives each map; a map carries the stamp of
the image it was made from (the disparity nodelet and the safety map keep the header stamp), so
delay = wall(map received) - wall(image with the same stamp received). Both are received through
the same kind of TCPROS connection by this process, so the transport to this node cancels out
apart from the map's own serialisation, which a real consumer of the map pays too.
Messages are taken as rospy.AnyMsg and only their header stamp is parsed (no deserialisation of
images: the probe must stay cheap on the shared 2-core machine).

Frames lost: the safety map publishes no map for frames skipped as stationary (000 Sec. IV, by
design), dropped (a newer frame replaced the waiting one: processing slower than input) or
rejected; the nodelets count these in their StageTimings / diagnostics. Per image this node also
knows whether a map came out. The counters of the other nodelets come from /diagnostics, whose
timer runs on the bag's clock (updated about once per simulated second).

The window: from the first image to `--tail` simulated seconds before the last one, because
bag_replay.launch's player is required: when the bag ends roslaunch stops every node, possibly
while the last frames are still in the pipeline.

Resident memory and CPU of the nodelet manager (the process holding every nodelet) are sampled
from /proc every `--sample` s. With --cpu C every thread of the manager is pinned to core C
(threads created later inherit the affinity), the one-core condition of the targets.
"""
import argparse
import json
import math
import os
import struct
import sys
import threading
import time
import xmlrpc.client

import rosgraph
import rosnode
import rospy
from diagnostic_msgs.msg import DiagnosticArray

# stereo_safety_map/StageTimings, parsed from its serialised form: the package's Python message
# module imports every message of the package, and one of them needs geometry_msgs' Python
# module, which Debian ships separately (python3-geometry-msgs), so the probe does not import it.
STAGE_FIELDS = ("integrate_ms", "height_map_ms", "segmentation_ms", "plane_fit_ms",
                "labelling_ms", "total_ms")
COUNTER_FIELDS = ("frames_received", "frames_processed", "frames_skipped_stationary",
                  "frames_dropped", "frames_rejected")


class StageTimings:
    def __init__(self, buff):
        _seq, secs, nsecs, n = struct.unpack_from("<IIII", buff, 0)
        self.stamp = secs + 1e-9 * nsecs
        off = 16 + n
        for k, v in zip(STAGE_FIELDS, struct.unpack_from("<6d", buff, off)):
            setattr(self, k, v)
        for k, v in zip(COUNTER_FIELDS, struct.unpack_from("<5Q", buff, off + 48)):
            setattr(self, k, v)

CLK_TCK = os.sysconf("SC_CLK_TCK")
PAGE = os.sysconf("SC_PAGE_SIZE")


def stamp_of(buff):
    """Header stamp (secs, nsecs) from a serialised message that starts with std_msgs/Header."""
    if len(buff) < 12:
        return None
    _seq, secs, nsecs = struct.unpack_from("<III", buff, 0)
    return (secs, nsecs)


def stamp_sec(s):
    return s[0] + 1e-9 * s[1]


def percentile(values, q):
    if not values:
        return None
    v = sorted(values)
    k = (len(v) - 1) * q / 100.0
    lo = int(math.floor(k))
    hi = int(math.ceil(k))
    return v[lo] + (v[hi] - v[lo]) * (k - lo)


def summary(values):
    if not values:
        return None
    return {"n": len(values), "min": min(values), "median": percentile(values, 50),
            "p95": percentile(values, 95), "max": max(values),
            "mean": sum(values) / len(values)}


def proc_cpu_seconds(pid):
    """utime + stime of the whole process [s]."""
    with open("/proc/%d/stat" % pid) as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / float(CLK_TCK)


def proc_rss_mb(pid):
    with open("/proc/%d/statm" % pid) as f:
        return int(f.read().split()[1]) * PAGE / 1048576.0


def pin_process(pid, cpu):
    """Pins every thread of pid to one core; returns the number of threads pinned."""
    n = 0
    try:
        tids = os.listdir("/proc/%d/task" % pid)
    except OSError:
        return 0
    for tid in tids:
        try:
            os.sched_setaffinity(int(tid), {cpu})
            n += 1
        except OSError:
            pass  # the thread ended meanwhile
    return n


def allowed_cpus(pid):
    cpus = set()
    try:
        for tid in os.listdir("/proc/%d/task" % pid):
            try:
                cpus |= os.sched_getaffinity(int(tid))
            except OSError:
                pass
    except OSError:
        pass
    return sorted(cpus)


class Probe:
    def __init__(self, args):
        self.args = args
        self.lock = threading.Lock()
        self.images = {}     # stamp -> wall time of the first reception
        self.image_order = []
        self.outputs = {}    # topic -> {stamp: wall time}
        self.timings = []    # (wall, StageTimings)
        self.diag = {}       # status name -> list of (stamp sec, wall, {key: value})
        self.samples = []    # (wall, rss MB, cpu s)
        self.pid = None
        self.pinned = 0
        self.last_image_wall = None

    # --- callbacks (rospy runs each subscription in its own thread)
    def on_image(self, msg):
        now = time.monotonic()
        s = stamp_of(msg._buff)
        if s is None:
            return
        with self.lock:
            if s not in self.images:
                self.images[s] = now
                self.image_order.append(s)
            self.last_image_wall = now

    def on_output(self, topic):
        def cb(msg):
            now = time.monotonic()
            s = stamp_of(msg._buff)
            if s is None:
                return
            with self.lock:
                self.outputs.setdefault(topic, {}).setdefault(s, now)
        return cb

    def on_timings(self, msg):
        now = time.monotonic()
        try:
            t = StageTimings(msg._buff)
        except struct.error:
            return
        with self.lock:
            self.timings.append((now, t))

    def on_diagnostics(self, msg):
        now = time.monotonic()
        t = msg.header.stamp.to_sec()
        with self.lock:
            for st in msg.status:
                values = {kv.key: kv.value for kv in st.values}
                self.diag.setdefault(st.name, []).append((t, now, values))

    # --- the manager process
    def find_manager(self):
        master = rosgraph.Master("/bench_ros_probe")
        try:
            uri = rosnode.get_api_uri(master, self.args.manager, skip_cache=True)
            if not uri:
                return None
            code, _msg, pid = xmlrpc.client.ServerProxy(uri).getPid("/bench_ros_probe")
            return pid if code == 1 else None
        except Exception:  # noqa: BLE001 - not up yet
            return None

    def sampler(self, stop):
        while not stop.is_set():
            pid = self.pid
            if pid is not None:
                try:
                    if self.args.cpu is not None and self.last_image_wall is None:
                        # Until the first image: nodelets may still be loading and making threads.
                        self.pinned = pin_process(pid, self.args.cpu)
                    sample = (time.monotonic(), proc_rss_mb(pid), proc_cpu_seconds(pid))
                    with self.lock:
                        self.samples.append(sample)
                except OSError:
                    pass
            stop.wait(self.args.sample)

    def alive(self):
        return self.pid is not None and os.path.exists("/proc/%d" % self.pid)

    # --- analysis
    def analyse(self):
        a = self.args
        with self.lock:
            order = sorted(self.image_order, key=stamp_sec)
            images = dict(self.images)
            outputs = {k: dict(v) for k, v in self.outputs.items()}
            timings = list(self.timings)
            diag = {k: list(v) for k, v in self.diag.items()}
            samples = list(self.samples)
        res = {"manager": a.manager, "manager_pid": self.pid, "pinned_cpu": a.cpu,
               "manager_cpus_allowed": allowed_cpus(self.pid) if self.alive() else None,
               "rate": a.rate, "tail_s": a.tail, "images_received": len(order)}
        if not order:
            res["error"] = "no image received"
            return res
        t_first = stamp_sec(order[0])
        t_end = stamp_sec(order[-1]) - a.tail
        window = [s for s in order if stamp_sec(s) <= t_end]
        if len(window) < 2:
            window = order
            t_end = stamp_sec(order[-1])
        wall0 = images[window[0]]
        wall1 = images[window[-1]]
        res["window"] = {"first_stamp": t_first, "last_stamp": t_end, "images": len(window),
                         "wall_s": wall1 - wall0,
                         "input_rate_hz": (len(window) - 1) / (wall1 - wall0)
                         if wall1 > wall0 else None}
        inwin = set(window)

        # Delay per output topic, for the frames of the window.
        res["outputs"] = {}
        for topic, got in outputs.items():
            delays = [1e3 * (got[s] - images[s]) for s in window if s in got]
            res["outputs"][topic] = {"messages": sum(1 for s in got if s in inwin),
                                     "delay_ms": summary(delays)}
        maps = outputs.get(a.map, {})
        res["maps"] = sum(1 for s in window if s in maps)
        res["images_without_map"] = len(window) - res["maps"]
        res["images_without_map_at_s"] = [round(stamp_sec(s) - t_first, 3) for s in window
                                           if s not in maps]

        # The safety map's own counters at its last map of the window, and its stage times.
        last = None
        totals = []
        stages = {k: [] for k in ("integrate_ms", "height_map_ms", "segmentation_ms",
                                  "plane_fit_ms", "labelling_ms", "total_ms")}
        for _wall, m in timings:
            if m.stamp > t_end + 1e-6:
                continue
            last = m
            for k in stages:
                stages[k].append(getattr(m, k))
            totals.append(m.total_ms)
        if last is not None:
            c = {"received": last.frames_received, "processed": last.frames_processed,
                 "stationary": last.frames_skipped_stationary, "dropped": last.frames_dropped,
                 "rejected": last.frames_rejected}
            res["safety_map_counters"] = c
            # Frames of the window that should have given a map and did not: not stationary.
            res["frames_lost"] = max(0, res["images_without_map"] - c["stationary"])
        res["safety_map_stage_ms"] = {k: summary(v) for k, v in stages.items()}

        # Other nodelets: the last diagnostics of the window (their timer runs on sim time).
        res["diagnostics"] = {}
        for name, entries in diag.items():
            inside = [e for e in entries if e[0] <= t_end + 1e-6]
            if not inside:
                continue
            t, _wall, values = inside[-1]
            keep = {k: v for k, v in values.items()
                    if k.startswith("frames") or k.startswith("processing time")
                    or k.startswith("input rate") or k.startswith("processed rate")
                    or k.startswith("disparity time")}
            if keep:
                res["diagnostics"][name] = {"stamp": t, "values": keep}

        # Manager: CPU per frame and memory.
        win_samples = [s for s in samples if wall0 <= s[0] <= wall1]
        if len(win_samples) >= 2:
            w0, _r0, c0 = win_samples[0]
            w1, _r1, c1 = win_samples[-1]
            frames = sum(1 for s in window if w0 <= images[s] <= w1)
            res["manager_cpu"] = {"cpu_s": c1 - c0, "wall_s": w1 - w0,
                                  "cores_used": (c1 - c0) / (w1 - w0) if w1 > w0 else None,
                                  "cpu_ms_per_image": 1e3 * (c1 - c0) / frames if frames else None}
        if samples:
            rss = [s[1] for s in samples]
            res["manager_rss_mb"] = {
                "at_first_image": next((s[1] for s in samples if s[0] >= wall0), rss[0]),
                "at_window_end": ([s[1] for s in samples if s[0] <= wall1] or rss)[-1],
                "max": max(rss), "samples": len(rss),
                "series": [[round(s[0] - wall0, 2), round(s[1], 2)] for s in samples]}
        return res


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", required=True, help="JSON file to write")
    p.add_argument("--manager", default="/safety_map_manager", help="nodelet manager node")
    p.add_argument("--image", default="/stereo/left/image_rect", help="left image topic")
    p.add_argument("--map", default="/safety_map", help="the safety map topic (the delay target)")
    p.add_argument("--extra", action="append", default=[],
                   help="more output topics with a header whose delay is reported")
    p.add_argument("--timings", default="/stage_timings", help="StageTimings topic")
    p.add_argument("--rate", type=float, default=1.0, help="rosbag play rate (reported)")
    p.add_argument("--cpu", type=int, default=None, help="pin the manager to this core")
    p.add_argument("--tail", type=float, default=1.0,
                   help="simulated seconds at the end of the bag left out of the window")
    p.add_argument("--sample", type=float, default=0.5, help="memory / CPU sampling period [s]")
    p.add_argument("--idle", type=float, default=4.0,
                   help="stop this many wall seconds after the last image")
    p.add_argument("--timeout", type=float, default=600.0, help="give up after this long [s]")
    a = p.parse_args()

    rospy.init_node("bench_ros_probe", anonymous=False, disable_signals=True)
    probe = Probe(a)
    rospy.Subscriber(a.image, rospy.AnyMsg, probe.on_image, tcp_nodelay=True)
    rospy.Subscriber(a.map, rospy.AnyMsg, probe.on_output(a.map), tcp_nodelay=True)
    for t in a.extra:
        rospy.Subscriber(t, rospy.AnyMsg, probe.on_output(t), tcp_nodelay=True)
    rospy.Subscriber(a.timings, rospy.AnyMsg, probe.on_timings, tcp_nodelay=True)
    rospy.Subscriber("/diagnostics", DiagnosticArray, probe.on_diagnostics, tcp_nodelay=True)

    stop = threading.Event()
    sampler = threading.Thread(target=probe.sampler, args=(stop,), daemon=True)
    sampler.start()
    start = time.monotonic()
    seen_manager = False
    while time.monotonic() - start < a.timeout:
        if probe.pid is None:
            probe.pid = probe.find_manager()
        elif not seen_manager:
            seen_manager = True
            print("[probe] manager %s: pid %d" % (a.manager, probe.pid), file=sys.stderr)
        if seen_manager and not probe.alive():
            break  # roslaunch stopped everything (the player is required)
        last = probe.last_image_wall
        if last is not None and time.monotonic() - last > a.idle:
            break
        time.sleep(0.2)
    stop.set()
    sampler.join(timeout=2.0)
    res = probe.analyse()
    res["timed_out"] = time.monotonic() - start >= a.timeout
    res["pinned_threads"] = probe.pinned
    with open(a.out, "w") as f:
        json.dump(res, f, indent=1)
    print("[probe] %d images, %d maps; results in %s" % (
        res.get("images_received", 0), res.get("maps", 0), a.out), file=sys.stderr)
    rospy.signal_shutdown("done")
    return 0 if res.get("maps", 0) > 0 else 1


if __name__ == "__main__":
    sys.exit(main())
