#!/usr/bin/env python3
"""What a one-shot `hedgefit` command pays before it does anything, and what `find` costs whole.

Usage: scripts/startup_time.py [--runs N] [HEDGEFIT]

Prints, for `hedgefit --version` (start-up alone), `hedgefit measure` on command 1's lab capture
(build/demo: start-up, decoding two PNGs, building the rectification maps and the whole
capture-to-sphere path once; skipped, saying so, before scripts/demo.sh has run) and `hedgefit
find` on the real garden half (start-up, reading the PLY and the search; skipped, saying so,
when the data are absent): the
median and range of the wall time over N runs (default 15 and 5), the peak resident memory (the
kernel's own count for each child, os.wait4), and the shared libraries the executable loads at
start-up (ldd: modules loaded later, on first use, are not among them).
"""
import os
import statistics
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from script_args import check_args, require_executable  # noqa: E402

check_args(__doc__, with_value=("--runs",))

args = sys.argv[1:]
runs = 15
if "--runs" in args:
    k = args.index("--runs")
    runs = int(args[k + 1])
    del args[k:k + 2]
exe = args[0] if args else "build/apps/hedgefit"
require_executable(exe)
data = os.environ.get("HEDGEFIT_DATA_DIR") or next((d for d in ("data", "../shared/data") if os.path.isdir(d)), "data")
garden = os.path.join(data, "gardens", "wageningen_west", "garden_west.ply")
lab = "build/demo/lab"
capture = ["measure", "--rig", "build/demo/rig.yaml", "--left", f"{lab}/sphere_2300_left.png",
           "--right", f"{lab}/sphere_2300_right.png"]
have_lab = all(os.path.isfile(f) for f in capture[2::2])


def timed(cmd, n):
    """Wall seconds and peak resident MiB of each of n runs of cmd (output discarded)."""
    walls, peaks = [], []
    for _ in range(n):
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        _, status, usage = os.wait4(proc.pid, 0)
        walls.append(time.perf_counter() - t0)
        proc.returncode = os.waitstatus_to_exitcode(status)
        if proc.returncode != 0:
            sys.exit(f"startup_time: {' '.join(cmd)} exited {proc.returncode}")
        peaks.append(usage.ru_maxrss / 1024)  # Linux reports KiB
    return walls, peaks


ldd = subprocess.run(["ldd", exe], capture_output=True, text=True, check=True).stdout
libraries = sum(1 for line in ldd.splitlines() if "=>" in line or line.strip().startswith("/"))
print(f"{exe}: {libraries} shared libraries at start-up (ldd); {os.cpu_count()} hardware threads")
print()
print(f"{'command':<48}{'runs':>5}{'median s':>10}{'min-max s':>14}{'peak MiB':>10}")
rows = [(["--version"], runs, "hedgefit --version")]
if have_lab:
    rows.append((capture, max(3, runs // 3), "hedgefit measure (lab capture, one-shot)"))
if os.path.isfile(garden):
    rows.append((["find", garden], max(3, runs // 3), "hedgefit find (real garden half, 114k points)"))
for extra, n, name in rows:
    timed([exe] + extra, 1)  # warm the page cache
    walls, peaks = timed([exe] + extra, n)
    print(f"{name:<48}{n:>5}{statistics.median(walls):>10.3f}{min(walls):>7.3f}-{max(walls):<6.3f}{max(peaks):>10.0f}")
if not have_lab:
    print("(measure skipped: build/demo/rig.yaml and its lab capture are absent; run scripts/demo.sh first)")
if not os.path.isfile(garden):
    print(f"(find skipped: {garden} is absent; docs/data.md says where the garden half comes from)")
