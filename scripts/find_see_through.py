#!/usr/bin/env python3
"""The see-through check's measure on data with known answers: what `find`'s threshold rests on.

Usage: scripts/find_see_through.py [--reuse] [HEDGEFIT] [GARDEN_DIR] [OUT_DIR]
(--reuse: read the scans an earlier run left in OUT_DIR instead of simulating them again)
A cloud that says nothing of where its sensor stood is judged as seen from above: of the points
over a ball's core on its top or past it (inside it, or under its underside), the share past it
(JSON `seen_through`); over 0.5 the ball is refused (docs/commands.md, `find`). Read here on:
  - the simulated gardens and beds of every sensor (`bench find --dir`), none told where the
    sensor stood: the true balls (within 0.3 radii of a truth), tuning seeds 1-3 and held-back
    seeds 101-103;
  - the real garden half turned about the vertical in 5-degree steps (0-355), whose map marks no
    ball: every object the check read.
Needs numpy. Nothing here is tuned.
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from garden_ply import read_garden_xyz  # noqa: E402
from find_runs import find_json as run_find, near_truth, simulated_scans  # noqa: E402
from script_args import check_args, require_executable  # noqa: E402

check_args(__doc__, flags=("--reuse",))

reuse = "--reuse" in sys.argv
sys.argv = [a for a in sys.argv if a != "--reuse"]
exe = sys.argv[1] if len(sys.argv) > 1 else "build/apps/hedgefit"
require_executable(exe)
data = os.environ.get("HEDGEFIT_DATA_DIR") or next((d for d in ("data", "../shared/data") if os.path.isdir(d)), "data")
garden = sys.argv[2] if len(sys.argv) > 2 else os.path.join(data, "gardens", "wageningen_west")
out_dir = sys.argv[3] if len(sys.argv) > 3 else "build/see_through"


def find_json(path):
    return run_find(exe, path)


print("| data (none told where the sensor stood) | objects the check read | share past them: true balls, max | other objects, their shares | refused (over 0.5) |")
print("|---|---|---|---|---|")
for first, what in ((1, "tuning seeds 1-3"), (101, "held-back seeds 101-103")):
    true_shares, other_shares = [], []
    for ply, truth in simulated_scans(exe, os.path.join(out_dir, f"seed{first}"), first, reuse):
        for h in find_json(ply):
            if "seen_through" not in h:
                continue
            is_true = h["ball"] and near_truth(h, truth)
            (true_shares if is_true else other_shares).append(h["seen_through"])
    refused = sum(s > 0.5 for s in true_shares + other_shares)
    others = ", ".join(f"{s:.2f}" for s in sorted(other_shares)) or "-"
    print(f"| simulated gardens and beds of 5 sensors, {what} | {len(true_shares) + len(other_shares)} "
          f"({len(true_shares)} true balls) | {max(true_shares):.2f} | {others} | {refused} |")


xyz = read_garden_xyz(os.path.join(garden, "garden_west.ply"))
shares = []
for deg in range(0, 360, 5):
    a = np.radians(deg)
    R = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    path = os.path.join(out_dir, "turned.xyz")
    np.savetxt(path, xyz @ R.T, fmt="%.4f")
    shares += [(h["seen_through"], deg) for h in find_json(path) if "seen_through" in h]
past = sorted(s for s, _ in shares)
refused = [s for s in past if s > 0.5]
kept = [s for s in past if s <= 0.5]
spread = f"{min(past):.2f}-{max(past):.2f}, {sum(s == 1 for s in past)} of them 1.00" if past else "-"
print(f"| the real garden half turned 0-355 degrees in 5-degree steps (its map marks no ball) | {len(shares)} in "
      f"{len(set(d for _, d in shares))} turns | - | {spread}{'; kept: ' + ', '.join(f'{s:.2f}' for s in kept) if kept else ''} | "
      f"{len(refused)} |")
