#!/usr/bin/env python3
"""Every stage, command and flag that README.md and docs/*.md name exists in today's build.

Stages: every `kind.name` token (readers., writers., filters., fitters., stereo., render.) must be a
stage `hedgefit plugins --json` lists. Commands and flags: in every code block and inline code span,
each `hedgefit COMMAND ...` invocation's command must exist and each of its --flags must appear in
`hedgefit COMMAND --help`. Usage: check_docs.py HEDGEFIT_EXE SOURCE_DIR. Exit 1 lists what is missing.
"""
import json
import pathlib
import re
import subprocess
import sys

exe, src = sys.argv[1], pathlib.Path(sys.argv[2])
docs = [src / "README.md"] + sorted((src / "docs").glob("*.md"))


def run(*args):
    return subprocess.run([exe, *args], capture_output=True, text=True, timeout=60)


stages = {s["name"] for s in json.loads(run("plugins", "--json").stdout)["stages"]}
helps = {}


def help_of(command):
    if command not in helps:
        r = run(*command.split(), "--help")
        helps[command] = r.stdout if r.returncode == 0 else None
    return helps[command]


STAGE = re.compile(r"\b((?:readers|writers|filters|fitters|stereo|render)\.[a-z][a-z0-9_]*)\b(?!\.(?:hpp|cpp|md|json|png|py|txt|yaml|h)\b)")
FILE_LIKE = re.compile(r"\.(hpp|cpp|md|json|png|py|txt|yaml|h)$")
INVOKE = re.compile(r"(?:^|[\s/`(])hedgefit ([a-z][a-z-]*)(?: (lab|garden)\b)?([^\n`]*)")
problems = []
for doc in docs:
    text = doc.read_text()
    rel = doc.relative_to(src)
    for m in STAGE.finditer(text):
        name = m.group(1)
        # "stereo.sgbm" is a stage; "stereo.hpp" or "fitters.envelope.leaf_depth" name a file or option
        if FILE_LIKE.search(name) or name in stages:
            continue
        problems.append(f"{rel}: stage '{name}' is not registered (hedgefit plugins)")
    # code: fenced blocks and inline spans, with shell line continuations joined
    code = re.findall(r"```[a-z]*\n(.*?)```", text, re.S) + re.findall(r"`([^`\n]+)`", text)
    for block in code:
        block = block.replace("\\\n", " ")
        for m in INVOKE.finditer(block):
            command = m.group(1) + (" " + m.group(2) if m.group(2) else "")
            if command in ("is", "measures", "module", "executable", "and", "the"):
                continue
            h = help_of(command)
            if h is None:
                problems.append(f"{rel}: 'hedgefit {command}' is not a command")
                continue
            rest = re.split(r"\s(?:\||>|;|&&|#)\s?", m.group(3))[0]
            for flag in re.findall(r"(?<![\w-])(--[a-z][a-z0-9-]*)", rest):
                if not re.search(r"(?<![\w-])" + re.escape(flag) + r"(?![\w-])", h):
                    problems.append(f"{rel}: 'hedgefit {command}' has no flag {flag}")
for p in sorted(set(problems)):
    print(p)
print(f"{len(docs)} documents checked: {len(set(problems))} problems")
sys.exit(1 if problems else 0)
