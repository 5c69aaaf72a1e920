#!/usr/bin/env bash
# Command 2: install dependencies, build everything (Release), run the whole test suite.
# Real-data tests read HEDGEFIT_DATA_DIR, else data/ (docs/data.md), else the workspace's folder.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DHEDGEFIT_BUILD_TESTS=ON
cmake --build build -j2
cd build
ctest --output-on-failure -j2
cd ..
# Every help page and quick block in README.md and docs/ as today's code prints it
# (scripts/make_docs.sh --check; about 8 minutes). Its examples start from command 1's demo.
bash scripts/demo.sh > build/demo.log 2>&1 || { tail -n 20 build/demo.log; exit 1; }
bash scripts/make_docs.sh --check
# A short libFuzzer run of each harness (clang, ASan + UBSan; see README "Fuzzing and sanitizers").
bash scripts/fuzz.sh 10
