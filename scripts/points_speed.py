#!/usr/bin/python3
"""The warm frame's time against the pixels matched and refined per hedge (`--max-points`).

Runs build/bench/bench_capture on the lab capture and on the pair of the paper's hedge size
(preset paper_pair) once per budget, and prints today's warm pipeline's median frame time for
each, with the pair's time as a multiple of the lab's from the same run (issue "One pass": at
most 2.5). docs/speed.md's table beside it gives what the budgets do to the accuracy.

Usage: scripts/points_speed.py [--frames N] [BUDGET ...]   (default: 10 frames; 60000 30000 15000 8000)
Run from the repository's root after a build.
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from capture_runs import first_line, run_lab_and_pair, take_frames  # noqa: E402
from script_args import check_args, refuse  # noqa: E402


def main():
    check_args(__doc__, with_value=("--frames",))
    frames, args = take_frames(sys.argv[1:])
    if not all(a.isdigit() and int(a) > 0 for a in args):
        refuse(f"budgets are whole numbers of pixels per hedge, not {' '.join(args)}")
    budgets = [int(a) for a in args] or [60000, 30000, 15000, 8000]
    for k, n in enumerate(budgets):
        t, output = run_lab_and_pair("points_speed", frames, ["--max-points", str(n)])
        if k == 0:
            print(first_line(output, frames))
            print(f"{'max points per hedge':>22} {'lab':>6} {'paper pair':>11} {'pair / lab':>11}")
        (lab, _), (pair, _) = t["lab"], t["paper"]
        print(f"{n:>22} {lab:>6} {pair:>11} {pair / lab:>10.1f}x")


if __name__ == "__main__":
    main()
