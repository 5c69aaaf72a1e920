"""What scripts/points_speed.py and scripts/modes_speed.py share: `--frames N` taken off the
command line, build/bench/bench_capture run on the lab capture and the pair of the paper's hedge
size with one setting, today's warm pipeline read from its text, and the table's first line."""
import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BENCH = ROOT / "build/bench/bench_capture"


def take_frames(args, default="10"):
    """(frames, the other words) from a checked command line (script_args.check_args)."""
    args = list(args)
    if "--frames" not in args:
        return default, args
    i = args.index("--frames")
    return args[i + 1], args[:i] + args[i + 2:]


def medians(output):
    """{scene: [frame ms, SGBM step ms or None]} of today's warm pipeline ("lab" and "paper"),
    from bench_capture's text."""
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


def run_lab_and_pair(script, frames, extra):
    """bench_capture on the lab and the pair, `extra` its further options: (medians, its text).
    Exits naming the command when the bench is missing, fails or prints no warm median."""
    if not BENCH.exists():
        raise SystemExit(f"{script}: {BENCH.relative_to(ROOT)} is missing: build first (cmake --build build)")
    cmd = [str(BENCH), "--scenes", "lab,paper", "--frames", frames, "--stock-frames", "0", *extra]
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    t = medians(proc.stdout)
    if proc.returncode != 0 or set(t) != {"lab", "paper"}:
        raise SystemExit(f"{script}: {' '.join(cmd)} failed:\n{proc.stderr}")
    return t, proc.stdout


def first_line(output, frames):
    """The table's first line: what was timed, and on how many threads bench_capture ran."""
    threads = re.search(r"(\d+) hardware threads", output)
    return (f"warm frame, today's pipeline, median of {frames} frames (ms), hedgefit's renderer, "
            f"{threads.group(1) if threads else 'unknown'} hardware threads")
