#!/usr/bin/python3
"""Regenerates every output shown in README.md and docs/*.md from today's code.

A shown output is a plain ``` block right after a marker line

    <!-- shown: COMMAND -->          run by default (seconds to a minute or two)
    <!-- shown slow: COMMAND -->     run only with --slow (POV-Ray renders, long benches)
    <!-- shown fails: COMMAND -->    an error example: the command must exit non-zero
    <!-- shown timed: COMMAND -->    run by default; its numbers are timings (or hang on them), so
                                     --check compares its words, not its numbers

or a Markdown table (lines starting with '|') right after

    <!-- table: COMMAND -->  /  <!-- table slow: COMMAND -->  /  <!-- table timed: COMMAND -->

whose COMMAND prints the table (scripts/accuracy_tables.py assembles the benches' JSON into one).
A slow block or table, when regenerated, is followed by a line "*Made by hedgefit VERSION on DATE
...*": --check does not rerun it, so it says which code made it.

Real data is read from data/ (docs/data.md); when it is absent, data/ is linked to
$HEDGEFIT_DATA_DIR or the workspace's ../shared/data where one exists.

COMMAND runs with bash from the repository's root, stdout and stderr together, and its output
replaces the block. Markers run in file order, so a marker may use what an earlier one made
(`simulate -o build/lab` before `calibrate --left 'build/lab/...'`). A command that fails (or
succeeds where it should fail) stops the script and leaves the file as it was.

tests/docs/check_docs.py fails when a docs page shows an output block without a marker.

Usage: scripts/make_docs_shown.py [--slow] [--check | --list] [--only TEXT] [FILE...]
  --check       regenerate every quick block (all but slow) in a temporary copy of the tree and
                fail, listing them, on any block that differs from the page: a figure gone stale.
                Blocks that read data/ are skipped, saying so, when it is absent.
  --list        list the markers; run nothing
  --only TEXT   run only the markers whose command contains TEXT (slow ones too); leave the rest
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MARKER = re.compile(r"^([ \t]*)<!-- shown( slow| fails| timed)?: (.*?) -->\n\1```[a-z]*\n(.*?)\1```\n"
                    r"(\n\1\*Made by hedgefit [^\n]*\*\n)?", re.S | re.M)
TABLE = re.compile(r"^<!-- table( slow| timed)?: (.*?) -->\n((?:\|.*\n)+)(\n\*Made by hedgefit [^\n]*\*\n)?", re.M)


def pages(root, args):
    files = [Path(a) for a in args] or [root / "README.md", *sorted((root / "docs").glob("*.md"))]
    return [f if f.is_absolute() else root / f for f in files]


def run(command, must_fail, cwd):
    started = time.time()
    proc = subprocess.run(["bash", "-c", command], cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
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


def scratch_tree():
    """A copy of the repository's tracked files, with build/ and data/ linked, for --check."""
    tree = Path(tempfile.mkdtemp(prefix="hedgefit_docs_check_"))
    listed = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, text=True)
    files = [f for f in listed.stdout.split("\0") if f] if listed.returncode == 0 else []
    if not files:
        raise SystemExit("make_docs_shown: --check needs a git checkout (it copies the tracked files)")
    for f in files:
        (tree / f).parent.mkdir(parents=True, exist_ok=True)
        if (ROOT / f).is_file():
            shutil.copy2(ROOT / f, tree / f)
    for name in ("build", "data"):
        if (ROOT / name).exists():
            (tree / name).symlink_to((ROOT / name).resolve())
    return tree


def stamp():
    """What made a slow block: today's build and date."""
    proc = subprocess.run([str(ROOT / "build/apps/hedgefit"), "--version"], capture_output=True, text=True)
    version = proc.stdout.strip() if proc.returncode == 0 else "hedgefit (version unknown)"
    return f"*Made by {version} on {time.strftime('%Y-%m-%d')}; a slow output, which the docs check does not rerun.*\n"


def words(text):
    """A timed block's text without its numbers: what --check compares of it."""
    return re.sub(r"[ \t]+", " ", re.sub(r"[-+]?\d+(\.\d+)?(e[-+]?\d+)?", "#", text))


def main():
    argv = sys.argv[1:]
    if "-h" in argv or "--help" in argv:
        print(__doc__)
        return
    unknown = [a for k, a in enumerate(argv) if a.startswith("-") and a not in ("--slow", "--check", "--list", "--only")
               and (k == 0 or argv[k - 1] != "--only")]
    if unknown:
        raise SystemExit(f"make_docs_shown: unknown option {unknown[0]}; see --help")
    link_data()
    only = None
    if "--only" in argv:
        k = argv.index("--only")
        if k + 1 >= len(argv):
            raise SystemExit("make_docs_shown: --only needs the text a marker's command contains")
        only = argv[k + 1]
        del argv[k:k + 2]
    slow = ("--slow" in argv or only is not None) and "--check" not in argv
    listing, check = "--list" in argv, "--check" in argv
    root = scratch_tree() if check else ROOT
    has_data = (ROOT / "data").is_dir()
    stale, skipped_data = [], []

    def skipped(command):
        return only is not None and only not in command

    def needs_absent_data(command):
        # the commands that read real data: a data/ path, or a script that looks for it itself
        reads = ("data/" in command or "find_real_table.py" in command or "find_perturbed.py" in command
                 or "startup_time.py" in command
                 or "accuracy_tables.py find" in command
                 or "accuracy_tables.py real" in command)
        if reads and not has_data:
            skipped_data.append(command)
            return True
        return False

    for page in pages(root, [a for a in argv if not a.startswith("--")]):
        text = page.read_text()
        rel = page.relative_to(root)

        def compare(kind, command, old, new):
            if not check:
                return
            same = words(old) == words(new) if kind == "timed" else old == new
            if not same:
                a, b = old.rstrip("\n").split("\n"), new.rstrip("\n").split("\n")
                k = next((i for i in range(min(len(a), len(b))) if a[i] != b[i]), min(len(a), len(b)))
                shown = a[k] if k < len(a) else "(nothing)"
                made = b[k] if k < len(b) else "(nothing)"
                # from a little before the first character that differs
                j = next((i for i in range(min(len(shown), len(made))) if shown[i] != made[i]), min(len(shown), len(made)))
                j = max(0, j - 30)
                stale.append(f"{rel}: `{command[:90]}`, line {k + 1}\n    page:  ...{shown[j:j + 100]}\n"
                             f"    today: ...{made[j:j + 100]}")

        def replace(m):
            indent, kind, command = m.group(1), (m.group(2) or "").strip(), m.group(3)
            if listing:
                print(f"{rel}: [{kind or 'default'}] {command}")
                return m.group(0)
            if (kind == "slow" and not slow) or skipped(command) or (check and needs_absent_data(command)):
                return m.group(0)
            out = run(command, kind == "fails", root)
            body = "".join(indent + line + "\n" for line in out.rstrip("\n").split("\n"))
            compare(kind, command, m.group(4), body)
            made = "\n" + indent + stamp() if kind == "slow" else ""
            return f"{indent}<!-- shown{' ' + kind if kind else ''}: {command} -->\n{indent}```\n{body}{indent}```\n{made}"

        def replace_table(m):
            kind, command = (m.group(1) or "").strip(), m.group(2)
            if listing:
                print(f"{rel}: [table{' ' + kind if kind else ''}] {command}")
                return m.group(0)
            if (kind == "slow" and not slow) or skipped(command) or (check and needs_absent_data(command)):
                return m.group(0)
            out = run(command, False, root)
            if not all(line.startswith("|") for line in out.strip().split("\n")):
                raise SystemExit(f"make_docs_shown: `{command}` printed something other than a Markdown table")
            compare(kind, command, m.group(3), out.strip() + "\n")
            made = "\n" + stamp() if kind == "slow" else ""
            return f"<!-- table{' ' + kind if kind else ''}: {command} -->\n{out.strip()}\n{made}"

        new = TABLE.sub(replace_table, MARKER.sub(replace, text))
        if new != text and not check:
            page.write_text(new)
            print(f"make_docs_shown: {rel}", file=sys.stderr)
    if check:
        shutil.rmtree(root, ignore_errors=True)
        for command in skipped_data:
            print(f"make_docs_shown: skipped (data/ is absent; docs/data.md): `{command[:90]}`", file=sys.stderr)
        for s in stale:
            print(s)
        print(f"make_docs_shown --check: {len(stale)} block(s) differ from today's code"
              + (" (run scripts/make_docs_shown.py and commit)" if stale else ""))
        sys.exit(1 if stale else 0)


if __name__ == "__main__":
    main()
