#!/usr/bin/python3
"""The warm frame's time against the pixels matched and refined per hedge (`--max-points`).

Runs build/bench/bench_capture on the lab capture and on the pair of the paper's hedge size
(preset paper_pair) once per budget, and prints today's warm pipeline's median frame time for
each, with the pair's time as a multiple of the lab's from the same run (issue "One pass": at
most 2.5). docs/speed.md's table beside it gives what the budgets do to the accuracy.

Usage: scripts/points_speed.py [--frames N] [BUDGET ...]   (default: 10 frames; 60000 30000 15000 8000)
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


def medians(output):
    """{scene: today's warm median, ms} from bench_capture's text."""
    out, scene = {}, None
    for line in output.splitlines():
        if line.startswith("lab capture"):
            scene = "lab"
        elif line.startswith("the paper's outdoor size"):
            scene = "paper"
        m = re.match(r"hedgefit, warm pipeline, one frame at a time\s+(\d+)", line)
        if m and scene:
            out[scene] = int(m.group(1))
    return out


def main():
    check_args(__doc__, with_value=("--frames",))
    args = sys.argv[1:]
    frames = "10"
    if "--frames" in args:
        i = args.index("--frames")
        frames = args[i + 1]
        del args[i:i + 2]
    if not all(a.isdigit() and int(a) > 0 for a in args):
        refuse(f"budgets are whole numbers of pixels per hedge, not {' '.join(args)}")
    budgets = [int(a) for a in args] or [60000, 30000, 15000, 8000]
    if not BENCH.exists():
        raise SystemExit(f"points_speed: {BENCH.relative_to(ROOT)} is missing: build first (cmake --build build)")
    for k, n in enumerate(budgets):
        cmd = [str(BENCH), "--scenes", "lab,paper", "--frames", frames, "--stock-frames", "0", "--max-points", str(n)]
        proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
        t = medians(proc.stdout)
        if proc.returncode != 0 or set(t) != {"lab", "paper"}:
            raise SystemExit(f"points_speed: {' '.join(cmd)} failed:\n{proc.stderr}")
        if k == 0:
            threads = re.search(r"(\d+) hardware threads", proc.stdout)  # as bench_capture ran
            print(f"warm frame, today's pipeline, median of {frames} frames (ms), hedgefit's renderer, "
                  f"{threads.group(1) if threads else 'unknown'} hardware threads")
            print(f"{'max points per hedge':>22} {'lab':>6} {'paper pair':>11} {'pair / lab':>11}")
        print(f"{n:>22} {t['lab']:>6} {t['paper']:>11} {t['paper'] / t['lab']:>10.1f}x")


if __name__ == "__main__":
    main()
