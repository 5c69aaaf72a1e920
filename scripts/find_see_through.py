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
import glob
import json
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from garden_ply import read_garden_xyz  # noqa: E402

reuse = "--reuse" in sys.argv
sys.argv = [a for a in sys.argv if a != "--reuse"]
exe = sys.argv[1] if len(sys.argv) > 1 else "build/apps/hedgefit"
data = os.environ.get("HEDGEFIT_DATA_DIR") or next((d for d in ("data", "../shared/data") if os.path.isdir(d)), "data")
garden = sys.argv[2] if len(sys.argv) > 2 else os.path.join(data, "gardens", "wageningen_west")
out_dir = sys.argv[3] if len(sys.argv) > 3 else "build/see_through"
sensors = "lidar16,lidar32,terrestrial,photogrammetry,aerial"


def find_json(path):
    run = subprocess.run([exe, "find", path, "--format", "json"], capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"{path}: find exited {run.returncode}: {run.stderr.strip()[:200]}")
    return json.loads(run.stdout)["clouds"][0]["hedges"]


print("| data (none told where the sensor stood) | objects the check read | share past them: true balls, max | other objects, their shares | refused (over 0.5) |")
print("|---|---|---|---|---|")
for first, what in ((1, "tuning seeds 1-3"), (101, "held-back seeds 101-103")):
    scans = os.path.join(out_dir, f"seed{first}")
    os.makedirs(scans, exist_ok=True)
    if not (reuse and glob.glob(os.path.join(scans, "*.truth.json"))):
        subprocess.run([exe, "bench", "find", "--sensors", sensors, "--first-seed", str(first), "--dir", scans],
                       capture_output=True, text=True, check=True)
    true_shares, other_shares = [], []
    for ply in sorted(glob.glob(os.path.join(scans, "*.ply"))):
        truth = json.load(open(ply[:-4] + ".truth.json")).get("hedges", [])
        for h in find_json(ply):
            if "seen_through" not in h:
                continue
            fit = h.get("fit") or {}
            c = np.array(fit.get("center_mm") or h.get("center_mm") or [np.inf] * 3)
            r = fit.get("radius_mm") or h.get("radius_mm") or 0
            is_true = h["ball"] and any(np.linalg.norm(np.array(t["center_mm"]) - c) < 0.3 * r for t in truth)
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
