#!/usr/bin/python3
"""Sorts ThreadSanitizer reports for scripts/test --tsan: ours, or third party.

Only our code is instrumented: the nodelet manager, roscpp, tf2, nodelet, boost.thread and
log4cxx come from Debian, uninstrumented, so TSan cannot see the happens-before edges made inside
them (atomics, their own queues) and reports races and lock-order cycles between their own
accesses, or between their deallocation and a message our callback read, that are not races.
A report is ours when the code that made one of its accesses, or took one of its mutexes, is
ours: the first frame of each stack that is not a sanitizer interceptor lies in this repository's
src/, include/stereo_safety_map/ or test/ (header code of third-party libraries inlined into our
libraries, e.g. ros/serialization.h or boost's shared_ptr, is theirs).

Usage: tsan_reports.py REPO_ROOT OUT_OURS FILE...  Prints a summary; writes our reports, whole,
to OUT_OURS; exits 1 when there is one.
"""
import collections
import os
import re
import subprocess
import sys

SECTION = re.compile(r"^\s*(Read|Write|Previous read|Previous write|Atomic|Previous atomic|"
                     r"Mutex \S+ acquired here|Mutex \S+ previously acquired)")
FRAME = re.compile(r"^\s*#\d+\s+(.*)$")
OUR_BINARY = re.compile(r"\((libstereo_safety_map\w*\.so|safety_map_\w+|disparity_\w+)\+0x")
INTERCEPTOR = re.compile(r"libtsan|libsanitizer|sanitizer_common|tsan_interceptors|"
                         r"tsan_new_delete|(^|\s)(memcpy|memcmp|memmove|memset|strlen|free|malloc|"
                         r"operator new|operator delete|pthread_\w+)\b")


def culprits(report):
    """The first non-interceptor frame of each access / lock stack."""
    out = []
    want = False
    for line in report.splitlines():
        if SECTION.match(line):
            want = True
            continue
        m = FRAME.match(line)
        if want and m:
            if INTERCEPTOR.search(m.group(1)):
                continue
            out.append(m.group(1))
            want = False
        elif not line.strip():
            want = False
    return out


_cache = {}


def symbolize(frame, libdirs):
    """'<null> <null> (libx.so+0x12)' of our binaries -> 'function file:line' via addr2line (the
    TSan runtime preloaded into the uninstrumented manager does not symbolise dlopen'ed plugins)."""
    m = re.search(r"<null> <null> \((\S+?)\+(0x[0-9a-f]+)\)", frame)
    if not m or not OUR_BINARY.search(frame):
        return frame
    key = (m.group(1), m.group(2))
    if key not in _cache:
        path = next((d + "/" + m.group(1) for d in libdirs if os.path.exists(d + "/" + m.group(1))),
                    None)
        text = frame
        if path:
            out = subprocess.run(["addr2line", "-f", "-C", "-i", "-e", path, m.group(2)],
                                 capture_output=True, text=True).stdout.splitlines()
            if len(out) >= 2 and not out[0].startswith("??"):
                text = "%s %s (%s+%s)" % (out[0], out[1], m.group(1), m.group(2))
        _cache[key] = text
    return _cache[key]


def main():
    root, out_path, files = sys.argv[1], sys.argv[2], sys.argv[3:]
    libdirs = [d for d in os.environ.get("SSM_TSAN_LIBDIRS", "").split(":") if d]
    ours_markers = [root + "/src/", root + "/include/stereo_safety_map/", root + "/test/",
                    "../../../src/", "../../../include/stereo_safety_map/", "../../../test/"]
    third = collections.Counter()
    ours = []
    total = 0
    for path in files:
        text = open(path, errors="replace").read()
        for block in text.split("==================\n"):
            if "WARNING: ThreadSanitizer" not in block:
                continue
            total += 1
            block = "\n".join(symbolize(l, libdirs) if "<null> <null>" in l else l
                              for l in block.splitlines())
            frames = culprits(block)
            # An unsymbolised frame of our libraries or test nodes counts as ours (cannot tell).
            unknown_ours = any("<null>" in f and OUR_BINARY.search(f) for f in frames)
            if unknown_ours or any(any(m in f for m in ours_markers) for f in frames):
                ours.append((path, block))
                continue
            kind = re.search(r"WARNING: ThreadSanitizer: ([a-z -]+)", block).group(1).strip()
            lib = "?"
            for f in frames:
                m = re.search(r"\(([^()+]+?)(\.so[.\d]*)?\+0x", f) or re.search(r"(\S+\.(h|hpp|cc|cpp)):\d+", f)
                if m:
                    lib = m.group(1).split("/")[-1]
                    break
            third[(kind, lib)] += 1
    with open(out_path, "w") as f:
        for path, block in ours:
            f.write("# %s\n%s\n==================\n" % (path, block))
    print("tsan: %d reports, %d in our code, %d between third-party accesses (not counted):"
          % (total, len(ours), total - len(ours)))
    for (kind, lib), n in third.most_common():
        print("  %5d  %-40s %s" % (n, kind, lib))
    return 1 if ours else 0


if __name__ == "__main__":
    sys.exit(main())
