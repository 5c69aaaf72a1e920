#!/usr/bin/env python3
"""The leaf-depth check's measure on data with known answers: what `find`'s --max-leaf-depth rests on.

Usage: scripts/find_leaf_depth.py [--reuse] [HEDGEFIT] [OUT_DIR]
(--reuse: read the scans an earlier run left in OUT_DIR instead of simulating them again; the
same scans as scripts/find_see_through.py's)
A clipped ball's leaves lie in a thin layer under its envelope: `find` refuses a ball whose mean
leaf lies deeper than 10 % of its radius (JSON `leaf_depth_mm` over `radius_mm`). A cloud that does
not say where it was seen from has its leaves laid along a guessed view or radially, whichever is
likelier (JSON `leaves`). Read here on every true ball `find` measured (within 0.3 radii of a
truth, called a ball or refused):
  - the simulated gardens and beds of every sensor (`bench find --dir`), tuning seeds 1-3 and
    held-back seeds 101-103;
  - the real Velodyne scans of one calibration sphere (sphere_scans/example2, 5 scans).
Needs numpy. Nothing here is tuned.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from find_runs import find_json, near_truth, simulated_scans, sphere_of  # noqa: E402
from script_args import check_args, require_executable  # noqa: E402

check_args(__doc__, flags=("--reuse",))

reuse = "--reuse" in sys.argv
sys.argv = [a for a in sys.argv if a != "--reuse"]
exe = sys.argv[1] if len(sys.argv) > 1 else "build/apps/hedgefit"
require_executable(exe)
out_dir = sys.argv[2] if len(sys.argv) > 2 else "build/see_through"
data = os.environ.get("HEDGEFIT_DATA_DIR") or next((d for d in ("data", "../shared/data") if os.path.isdir(d)), "data")


def row(what, balls):
    """balls: (leaf depth over radius, leaves laid radially, called a ball) per true ball."""
    if not balls:
        print(f"| {what} | 0 | - | - | - | - |")
        return
    shares = sorted(s for s, _, _ in balls)
    radial = sum(r for _, r, _ in balls)
    median = shares[len(shares) // 2]
    print(f"| {what} | {len(balls)} | {radial} | {median:.3f} | {shares[-1]:.3f} | {sum(s > 0.1 for s in shares)} |")


def read(h):
    _, r = sphere_of(h)
    return (h["leaf_depth_mm"] / r, h.get("leaves") == "radial", h["ball"])


print("| data (true balls `find` measured) | balls | leaves laid radially | leaf depth over radius: median | max | over 0.10 (refused) |")
print("|---|---|---|---|---|---|")
for first, what in ((1, "tuning seeds 1-3"), (101, "held-back seeds 101-103")):
    balls = [read(h) for ply, truth in simulated_scans(exe, os.path.join(out_dir, f"seed{first}"), first, reuse)
             for h in find_json(exe, ply) if "leaf_depth_mm" in h and near_truth(h, truth)]
    row(f"simulated gardens and beds of 5 sensors, {what}", balls)
scans = [os.path.join(data, "sphere_scans", "example2", f"L1_S{i}.xyz") for i in range(1, 6)]
if all(os.path.exists(p) for p in scans):
    # One sphere in each scan: every ball `find` measured near it (the scans' own fits say r ~0.3 m).
    row("real Velodyne VLP-16 scans of one sphere (sphere_scans/example2, 5 scans)",
        [read(h) for p in scans for h in find_json(exe, p) if "leaf_depth_mm" in h and h["ball"]])
else:
    print("| real Velodyne scans (sphere_scans/example2): not in the data folder | - | - | - | - | - |")
