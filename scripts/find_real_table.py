#!/usr/bin/env python3
"""`hedgefit find` on a real garden model against its annotated map: found, false, per class.

Usage: scripts/find_real_table.py [--per-topiary | --measures] [HEDGEFIT] [GARDEN_DIR]
GARDEN_DIR holds garden_*.ply and objects.json (the TrimBot2020 map format: label, position_m,
diameters_m); default gardens/wageningen_west in $HEDGEFIT_DATA_DIR, else data/, else ../shared/data.
An object is found when a topiary (any clipped shape) lies within 200 mm of an annotated
Topiary's centre in the top view; every other topiary is false, named after the nearest
annotated object. Prints a markdown table: the score, or with --per-topiary each annotated
topiary, what was found there and the measures its verdict rests on; with --measures every object
judged as a clipped shape by height, the map's nearest label, and each measure a threshold reads.
"""
import glob
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from script_args import check_args, require_executable  # noqa: E402

check_args(__doc__, flags=("--per-topiary", "--measures"))
per_topiary = "--per-topiary" in sys.argv
measures = "--measures" in sys.argv
args = [a for a in sys.argv[1:] if a not in ("--per-topiary", "--measures")]
exe = args[0] if len(args) > 0 else "build/apps/hedgefit"
require_executable(exe)
# The data folder as the tests find it: HEDGEFIT_DATA_DIR, else data/, else the workspace's.
data = os.environ.get("HEDGEFIT_DATA_DIR") or next((d for d in ("data", "../shared/data") if os.path.isdir(d)), "data")
garden = args[1] if len(args) > 1 else os.path.join(data, "gardens", "wageningen_west")
clouds = sorted(glob.glob(os.path.join(garden, "*.ply")))
if not clouds:
    sys.exit(f"find_real_table: no cloud in {garden}: set HEDGEFIT_DATA_DIR to the folder that holds gardens/wageningen_west")
objects = json.load(open(os.path.join(garden, "objects.json")))["objects"]
out = subprocess.run([exe, "find", clouds[0], "--format", "json"], check=True, capture_output=True, text=True).stdout
cloud = json.loads(out)["clouds"][0]
truth = [(1000 * o["position_m"][0], 1000 * o["position_m"][1]) for o in objects if o["label"].startswith("Topiary")]
# The map's extents of each topiary: its diameters along the map's heading (semi-axes here), and
# its height.
extents = [(500 * o["diameters_m"][0], 500 * o["diameters_m"][1], 1000 * o["diameters_m"][2])
           for o in objects if o["label"].startswith("Topiary")]


def nearest_label(x, y):
    best = min(objects, key=lambda o: (1000 * o["position_m"][0] - x) ** 2 + (1000 * o["position_m"][1] - y) ** 2)
    return best["label"]


shapes = [h for h in cloud["hedges"] if h["topiary"]]
used, rows = set(), []
for tx, ty in truth:
    hit = None
    for h in shapes:
        c = h["shape"]["center_mm"] if "shape" in h else h["center_mm"]
        d = ((c[0] - tx) ** 2 + (c[1] - ty) ** 2) ** 0.5
        if h["id"] not in used and d < 200 and (hit is None or d < hit[1]):
            hit = (h, d)
    if hit:
        used.add(hit[0]["id"])
    rows.append(((tx, ty), hit))
false = [h for h in shapes if h["id"] not in used]
classes = {}
for h in shapes:
    if h["id"] in used:
        classes[h["verdict"]] = classes.get(h["verdict"], 0) + 1
if measures:
    def label(h):
        x, y = h["shape"]["center_mm"][:2]
        if any(((x - tx) ** 2 + (y - ty) ** 2) ** 0.5 < 250 for tx, ty in truth):
            return "**topiary**"
        return nearest_label(x, y)
    rows = sorted((h for h in cloud["hedges"] if "shape" in h), key=lambda h: (label(h) != "**topiary**", label(h)))
    print("| map's nearest object | called topiary | shape | semi-axes (mm) | top (mm) | longer or taller over wide "
          "(max 2) | cover (lower 95 % bound, min 0.7) | density over the lawn's (min 0.8) | roughness / noise (max 3.5) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for h in rows:
        s = h["shape"]
        print(f"| {label(h)} | {'yes' if h['topiary'] else 'no'} | {s['shape']} | "
              f"{' x '.join(f'{a:.0f}' for a in s['axes_mm'])} | {s['top_mm']:.0f} | {s['elongation']:.2f} | "
              f"{s['covered']:.2f} ({s['covered_lower']:.2f}) | {s['density']:.1f} | {s['roughness_noise']:.1f} |")
    sys.exit(0)
if not per_topiary:
  # The lawn's scatter about the terrain model: the noise the roughness column of --measures is over.
  print(f"| data | topiary annotated | found (within 200 mm) | false | classes of those found | lawn's noise (mm) | time |")
  print("|---|---|---|---|---|---|---|")
  print(f"| real: {os.path.basename(clouds[0])}, {cloud['points']} points | {len(truth)} | {len(used)} | {len(false)}"
      f"{' (' + ', '.join(nearest_label(*h['center_mm'][:2]) for h in false) + ')' if false else ''} | "
      f"{', '.join(f'{n} {k}' for k, n in sorted(classes.items()))} | {cloud['ground']['noise_mm']:.1f} | "
      f"{sum(cloud['timings_ms'].values()) / 1000:.2f} s |")
  sys.exit(0)
print("| annotated centre (m) | map's semi-axes x height (mm) | found | off (mm) | class | semi-axes (mm) | top (mm) | "
      "leaf layer (mm) | covered | roughness / noise |")
print("|---|---|---|---|---|---|---|---|---|---|")
wide, tall = [], []
for ((tx, ty), hit), (ea, eb, eh) in zip(rows, extents):
    mapped = f"{ea:.0f} x {eb:.0f} x {eh:.0f}"
    if not hit:
        print(f"| {tx / 1000:.2f}, {ty / 1000:.2f} | {mapped} | no | | | | | | | |")
        continue
    h, d = hit
    s = h.get("shape")
    axes = " x ".join(f"{a:.0f}" for a in s["axes_mm"]) if s else f"r {h['radius_mm']:.0f}"
    if s:
        wide.append(0.5 * (s["axes_mm"][0] + s["axes_mm"][1]) - 0.5 * (ea + eb))
        tall.append(s["top_mm"] - eh)
    print(f"| {tx / 1000:.2f}, {ty / 1000:.2f} | {mapped} | {h['id']} | {d:.0f} | {h['verdict']} | {axes} | "
          f"{s['top_mm']:.0f} | {s.get('envelope_offset_mm', 0):.0f} | {100 * s['covered']:.0f} % | {s['roughness_noise']:.1f} |" if s else
          f"| {tx / 1000:.2f}, {ty / 1000:.2f} | {mapped} | {h['id']} | {d:.0f} | {h['verdict']} | {axes} | | | | |")
if wide:
    print(f"| **found less the map's**, mean (range) | horizontal semi-axis {sum(wide) / len(wide):+.0f} "
          f"({min(wide):+.0f} to {max(wide):+.0f}), top against height {sum(tall) / len(tall):+.0f} "
          f"({min(tall):+.0f} to {max(tall):+.0f}) | | | | | | | | |")
