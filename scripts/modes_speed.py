#!/usr/bin/python3
"""The warm frame's time against stereo.sgbm's mode (which of OpenCV's SGBM variants matches).

Runs build/bench/bench_capture on the lab capture and on the pair of the paper's hedge size once per
mode (`--sgbm-mode`), and prints today's warm pipeline's median frame time and the median of its
SGBM step (SGBM with the right matcher and the left-right check) in each scene, with the pair's
frame as a multiple of the lab's from the same run. `scripts/accuracy_tables.py modes` gives what
each mode does to the envelope on the paper's hedge size.

Usage: scripts/modes_speed.py [--frames N] [MODE ...]   (default: 10 frames; hh sgbm 3way hh4)
Run from the repository's root after a build.
"""
import re
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from script_args import check_args, refuse  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
BENCH = ROOT / "build/bench/bench_capture"
MODES = ["hh", "sgbm", "3way", "hh4"]


def medians(output):
    """{scene: (frame ms, SGBM step ms)} of today's warm pipeline, from bench_capture's text."""
    out, scene, today = {}, None, False
    for line in output.splitlines():
        if line.startswith("lab capture"):
            scene = "lab"
        elif line.startswith("the paper's outdoor size"):
            scene = "paper"
        path = re.match(r"(\S.*?)\s+(\d+)\s+\d+\s+\d+", line)
        if path:
            today = path.group(1).startswith("hedgefit, warm pipeline, one frame at a time")
            if today and scene:
                out[scene] = [int(path.group(2)), None]
        step = re.match(r"\s+SGBM \+ right matcher \+ LR check\s+([\d.]+)", line)
        if step and today and scene in out:
            out[scene][1] = float(step.group(1))
    return out


def main():
    check_args(__doc__, with_value=("--frames",))
    args = sys.argv[1:]
    frames = "10"
    if "--frames" in args:
        i = args.index("--frames")
        frames = args[i + 1]
        del args[i:i + 2]
    if any(a not in MODES for a in args):
        refuse(f"modes are {', '.join(MODES)}, not {' '.join(args)}")
    if not BENCH.exists():
        raise SystemExit(f"modes_speed: {BENCH.relative_to(ROOT)} is missing: build first (cmake --build build)")
    for k, mode in enumerate(args or MODES):
        cmd = [str(BENCH), "--scenes", "lab,paper", "--frames", frames, "--stock-frames", "0", "--sgbm-mode", mode]
        proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
        t = medians(proc.stdout)
        if proc.returncode != 0 or set(t) != {"lab", "paper"} or any(v[1] is None for v in t.values()):
            raise SystemExit(f"modes_speed: {' '.join(cmd)} failed:\n{proc.stderr}")
        if k == 0:
            threads = re.search(r"(\d+) hardware threads", proc.stdout)
            print(f"warm frame, today's pipeline, median of {frames} frames (ms), hedgefit's renderer, "
                  f"{threads.group(1) if threads else 'unknown'} hardware threads")
            print(f"{'SGBM mode':>10} {'lab':>6} {'its SGBM':>9} {'paper pair':>11} {'its SGBM':>9} {'pair / lab':>11}")
        (lab, lab_sgbm), (pair, pair_sgbm) = t["lab"], t["paper"]
        print(f"{mode:>10} {lab:>6} {lab_sgbm:>9.1f} {pair:>11} {pair_sgbm:>9.1f} {pair / lab:>10.1f}x")


if __name__ == "__main__":
    main()
