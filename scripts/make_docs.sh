#!/usr/bin/env bash
# Regenerates what README.md and docs/ show from today's code (run after a build):
#   docs/cli/COMMAND.txt      each command's --help as the build prints it;
#   README.md's quick start   runs the quick start's commands exactly as README.md gives them, in a
#                             scratch folder, and puts their output between the quickstart markers;
#   docs/quickstart_output.txt  the same output, whole;
#   every <!-- shown: COMMAND --> block and <!-- table: COMMAND --> table in README.md and docs/
#                             (scripts/make_docs_shown.py; pass --slow to also re-run the POV-Ray
#                             benches, the accuracy tables (scripts/accuracy_tables.py) and
#                             bench_middlebury: an hour or more, POV-Ray's renders when missing).
# The pictures in docs/ come from scripts/make_docs_pictures.sh.
# --check changes nothing: it fails when a help page or a quick block (all but slow) differs from
# what today's build prints (scripts/make_docs_shown.py --check, in a temporary copy of the tree).
set -euo pipefail
cd "$(dirname "$0")/.."
H=./build/apps/hedgefit
[ -x "$H" ] || { echo "make_docs: build first ($H is missing)" >&2; exit 1; }
# The examples read real data from data/ (docs/data.md); link it where this workspace keeps it.
if [ ! -e data ]; then
  for d in "${HEDGEFIT_DATA_DIR:-}" ../shared/data; do
    if [ -n "$d" ] && [ -d "$d" ]; then ln -sfn "$(cd "$d" && pwd)" data; break; fi
  done
fi
if [ "${1:-}" = "--check" ]; then
  T=$(mktemp -d)
  stale=0
  for c in info pipeline plugins compare find simulate calibrate render convert measure stream trim rig check-rig \
           "bench lab" "bench garden" "bench find" "bench around"; do
    "$H" $c --help > "$T/help.txt"
    cmp -s "$T/help.txt" "docs/cli/${c// /-}.txt" || { echo "make_docs --check: docs/cli/${c// /-}.txt differs from 'hedgefit $c --help'"; stale=1; }
  done
  rm -rf "$T"
  /usr/bin/python3 scripts/make_docs_shown.py --check || stale=1
  [ $stale = 0 ] || { echo "make_docs --check: run scripts/make_docs.sh and commit what it changes" >&2; exit 1; }
  exit 0
fi
mkdir -p docs/cli
for c in info pipeline plugins compare find simulate calibrate render convert measure stream trim rig check-rig \
         "bench lab" "bench garden" "bench find" "bench around"; do
  "$H" $c --help > "docs/cli/${c// /-}.txt"
done

# The quick start: the first ```sh block after "## Quick start" in README.md, run as written.
Q=build/docs/quickstart
rm -rf "$Q" && mkdir -p "$Q/build"
ln -s "$PWD/build/apps" "$Q/build/apps"
/usr/bin/python3 - README.md > "$Q/quickstart.sh" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
start = text.index("## Quick start")
print(re.search(r"```sh\n(.*?)```", text[start:], re.S).group(1))
PY
(cd "$Q" && bash -e quickstart.sh > output.txt 2> stderr.txt) || {
  echo "make_docs: the quick start failed:" >&2; cat "$Q/stderr.txt" >&2; exit 1; }
cp "$Q/output.txt" docs/quickstart_output.txt
/usr/bin/python3 - "$Q/output.txt" README.md <<'PY'
import json, re, sys
out, readme = sys.argv[1], sys.argv[2]
keep = ("hedge", "method", "converged", "center_mm", "radius_mm", "ci95_mm", "points_used", "rig_check")
shown = []
for line in open(out):
    line = line.strip()
    if line.startswith("{"):
        d = json.loads(line)
        shown.append(json.dumps({k: d[k] for k in keep if k in d}, separators=(",", ":")))
text = open(readme).read()
block = "<!-- quickstart:begin -->\n```\n" + "\n".join(shown) + "\n```\n<!-- quickstart:end -->"
text = re.sub(r"<!-- quickstart:begin -->.*?<!-- quickstart:end -->", lambda m: block, text, flags=re.S)
open(readme, "w").write(text)
PY
/usr/bin/python3 scripts/make_docs_shown.py "$@"
echo "make_docs: docs/cli/ ($(ls docs/cli | wc -l) commands), README quick start and docs/quickstart_output.txt"
