#!/usr/bin/env python3
"""Lists the functions of hedgefit's C++ sources longer than N lines (default 80), longest first.

A function is a definition that starts at the first column (or one indentation level inside a
class) and ends at its matching closing brace. Tests are left out. Usage:
  scripts/long_functions.py [--over N] [--fail-over M] [DIR ...]
With --fail-over M it exits 1 when any function is longer than M lines (the project's limit is 120).
"""
import argparse
import pathlib
import re
import sys

ap = argparse.ArgumentParser()
ap.add_argument("--over", type=int, default=80)
ap.add_argument("--fail-over", type=int, default=0)
ap.add_argument("dirs", nargs="*")
args = ap.parse_args()
root = pathlib.Path(__file__).resolve().parent.parent
dirs = args.dirs or ["pipeline", "cloud", "stereo", "fitting", "eval", "scene", "io", "cli", "render", "sim", "bench", "apps", "python", "tools", "fuzz"]

HEAD = re.compile(r"^(?:  )?(?:[A-Za-z_][\w:<>,\*& ~]*?\s)?([A-Za-z_][\w:~]*)\s*\([^;]*$")
SKIP = re.compile(r"^\s*(if|for|while|switch|return|else|namespace|struct|class|enum|using|typedef|#)")


def strip(line):
    line = re.sub(r'"(\\.|[^"\\])*"', '""', line)
    line = re.sub(r"'(\\.|[^'\\])'", "''", line)
    return line.split("//")[0]


found = []
for d in dirs:
    for f in sorted((root / d).rglob("*.[ch]pp")):
        lines = f.read_text(errors="replace").split("\n")
        i = 0
        while i < len(lines):
            m = HEAD.match(lines[i])
            if m and not SKIP.match(lines[i]):
                # the signature may run over several lines up to its '{'
                j = i
                sig = strip(lines[i])
                while "{" not in sig and ";" not in sig and j + 1 < len(lines) and j - i < 8:
                    j += 1
                    sig += strip(lines[j])
                if "{" in sig and ";" not in sig.split("{")[0]:
                    depth = 0
                    k = i
                    started = False
                    while k < len(lines):
                        s = strip(lines[k])
                        depth += s.count("{") - s.count("}")
                        if "{" in s:
                            started = True
                        if started and depth <= 0:
                            break
                        k += 1
                    n = k - i + 1
                    if n > args.over:
                        found.append((n, f"{f.relative_to(root)}:{i + 1}", m.group(1)))
                    i = k + 1
                    continue
            i += 1
found.sort(reverse=True)
for n, where, name in found:
    print(f"{n:5d}  {name:40s} {where}")
if args.fail_over and any(n > args.fail_over for n, _, _ in found):
    print(f"{sum(n > args.fail_over for n, _, _ in found)} functions over {args.fail_over} lines", file=sys.stderr)
    sys.exit(1)
