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
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from capture_runs import first_line, run_lab_and_pair, take_frames  # noqa: E402
from script_args import check_args, refuse  # noqa: E402

MODES = ["hh", "sgbm", "3way", "hh4"]


def main():
    check_args(__doc__, with_value=("--frames",))
    frames, args = take_frames(sys.argv[1:])
    if any(a not in MODES for a in args):
        refuse(f"modes are {', '.join(MODES)}, not {' '.join(args)}")
    for k, mode in enumerate(args or MODES):
        t, output = run_lab_and_pair("modes_speed", frames, ["--sgbm-mode", mode])
        if any(v[1] is None for v in t.values()):
            raise SystemExit(f"modes_speed: bench_capture --sgbm-mode {mode} printed no SGBM step")
        if k == 0:
            print(first_line(output, frames))
            print(f"{'SGBM mode':>10} {'lab':>6} {'its SGBM':>9} {'paper pair':>11} {'its SGBM':>9} {'pair / lab':>11}")
        (lab, lab_sgbm), (pair, pair_sgbm) = t["lab"], t["paper"]
        print(f"{mode:>10} {lab:>6} {lab_sgbm:>9.1f} {pair:>11} {pair_sgbm:>9.1f} {pair / lab:>10.1f}x")


if __name__ == "__main__":
    main()
