"""What the `find` scripts share: running `find` for its JSON, and the simulated gardens and beds
of every sensor (`bench find --dir`) with their truth."""
import glob
import json
import os
import subprocess
import sys

import numpy as np

SENSORS = "lidar16,lidar32,terrestrial,photogrammetry,aerial"


def find_json(exe, path):
    """The hedges `find` reports in one cloud file (JSON), or exit with why."""
    run = subprocess.run([exe, "find", path, "--format", "json"], capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"{path}: find exited {run.returncode}: {run.stderr.strip()[:200]}")
    return json.loads(run.stdout)["clouds"][0]["hedges"]


def simulated_scans(exe, scans, first, reuse):
    """(PLY path, its true hedges) of `bench find`'s scans of seeds first..first+2, made in `scans`
    (or read from an earlier run there, with reuse)."""
    os.makedirs(scans, exist_ok=True)
    if not (reuse and glob.glob(os.path.join(scans, "*.truth.json"))):
        subprocess.run([exe, "bench", "find", "--sensors", SENSORS, "--first-seed", str(first), "--dir", scans],
                       capture_output=True, text=True, check=True)
    return [(ply, json.load(open(ply[:-4] + ".truth.json")).get("hedges", []))
            for ply in sorted(glob.glob(os.path.join(scans, "*.ply")))]


def sphere_of(h):
    """A reported hedge's centre and radius (its final fit's, else its own)."""
    fit = h.get("fit") or {}
    c = np.array(fit.get("center_mm") or h.get("center_mm") or [np.inf] * 3, dtype=float)
    return c, fit.get("radius_mm") or h.get("radius_mm") or 0


def near_truth(h, truth):
    """Whether a reported sphere lies within 0.3 of its radius of a true ball's centre."""
    c, r = sphere_of(h)
    return any(np.linalg.norm(np.array(t["center_mm"]) - c) < 0.3 * r for t in truth)
