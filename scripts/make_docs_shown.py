#!/usr/bin/python3
"""Regenerates every output shown in README.md and docs/*.md from today's code.

A shown output is a plain ``` block right after a marker line

    <!-- shown: COMMAND -->          run by default (seconds to a minute or two)
    <!-- shown slow: COMMAND -->     run only with --slow (POV-Ray renders, long benches)
    <!-- shown fails: COMMAND -->    an error example: the command must exit non-zero

or a Markdown table (lines starting with '|') right after

    <!-- table: COMMAND -->  /  <!-- table slow: COMMAND -->

whose COMMAND prints the table (scripts/accuracy_tables.py assembles the benches' JSON into one).

Real data is read from data/ (docs/data.md); when it is absent, data/ is linked to
$HEDGEFIT_DATA_DIR or the workspace's ../shared/data where one exists.

COMMAND runs with bash from the repository's root, stdout and stderr together, and its output
replaces the block. Markers run in file order, so a marker may use what an earlier one made
(`simulate -o build/lab` before `calibrate --left 'build/lab/...'`). A command that fails (or
succeeds where it should fail) stops the script and leaves the file as it was.

tests/docs/check_docs.py fails when a docs page shows an output block without a marker.

Usage: scripts/make_docs_shown.py [--slow] [--check] [--only TEXT] [FILE...]
  --check       list the markers and whether each block is there; run nothing
  --only TEXT   run only the markers whose command contains TEXT (slow ones too); leave the rest
"""
import os
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MARKER = re.compile(r"^([ \t]*)<!-- shown( slow| fails)?: (.*?) -->\n\1```[a-z]*\n(.*?)\1```\n", re.S | re.M)
TABLE = re.compile(r"^<!-- table( slow)?: (.*?) -->\n((?:\|.*\n)+)", re.M)


def pages(args):
    files = [Path(a) for a in args] or [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    return [f if f.is_absolute() else ROOT / f for f in files]


def run(command, must_fail):
    started = time.time()
    proc = subprocess.run(["bash", "-c", command], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True)
    failed = proc.returncode != 0
    if failed != must_fail:
        sys.stderr.write(proc.stdout)
        what = "exited 0 but is shown as an error" if must_fail else f"exited {proc.returncode}"
        raise SystemExit(f"make_docs_shown: `{command}` {what}")
    if not proc.stdout.strip():
        raise SystemExit(f"make_docs_shown: `{command}` printed nothing to show")
    print(f"  {time.time() - started:6.1f} s  {command[:100]}", file=sys.stderr)
    return proc.stdout


def link_data():
    """The docs' examples read real data from data/ (docs/data.md). When it is not there, link it to
    $HEDGEFIT_DATA_DIR or the workspace's ../shared/data, if either is."""
    link = ROOT / "data"
    if link.exists():
        return
    for source in (os.environ.get("HEDGEFIT_DATA_DIR"), str(ROOT.parent / "shared/data")):
        if source and Path(source).is_dir():
            if link.is_symlink():
                link.unlink()
            link.symlink_to(Path(source).resolve())
            print(f"make_docs_shown: data/ -> {Path(source).resolve()}", file=sys.stderr)
            return


def main():
    link_data()
    argv = sys.argv[1:]
    only = None
    if "--only" in argv:
        k = argv.index("--only")
        if k + 1 >= len(argv):
            raise SystemExit("make_docs_shown: --only needs the text a marker's command contains")
        only = argv[k + 1]
        del argv[k:k + 2]
    slow = "--slow" in argv or only is not None
    check = "--check" in argv

    def skipped(command):
        return only is not None and only not in command

    for page in pages([a for a in argv if not a.startswith("--")]):
        text = page.read_text()

        def replace(m):
            indent, kind, command = m.group(1), (m.group(2) or "").strip(), m.group(3)
            if check:
                print(f"{page.relative_to(ROOT)}: [{kind or 'default'}] {command}")
                return m.group(0)
            if (kind == "slow" and not slow) or skipped(command):
                return m.group(0)
            out = run(command, kind == "fails")
            body = "".join(indent + line + "\n" for line in out.rstrip("\n").split("\n"))
            return f"{indent}<!-- shown{' ' + kind if kind else ''}: {command} -->\n{indent}```\n{body}{indent}```\n"

        def replace_table(m):
            kind, command = (m.group(1) or "").strip(), m.group(2)
            if check:
                print(f"{page.relative_to(ROOT)}: [table{' ' + kind if kind else ''}] {command}")
                return m.group(0)
            if (kind == "slow" and not slow) or skipped(command):
                return m.group(0)
            out = run(command, False)
            if not all(line.startswith("|") for line in out.strip().split("\n")):
                raise SystemExit(f"make_docs_shown: `{command}` printed something other than a Markdown table")
            return f"<!-- table{' ' + kind if kind else ''}: {command} -->\n{out.strip()}\n"

        new = TABLE.sub(replace_table, MARKER.sub(replace, text))
        if new != text:
            page.write_text(new)
            print(f"make_docs_shown: {page.relative_to(ROOT)}", file=sys.stderr)


if __name__ == "__main__":
    main()
