#!/usr/bin/env bash
# Command 2: install dependencies, build everything (Release), run the whole test suite.
# Real-data tests read ../shared/data (override with HEDGEFIT_DATA_DIR).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DHEDGEFIT_BUILD_TESTS=ON
cmake --build build -j2
cd build
ctest --output-on-failure -j2
cd ..
# A short libFuzzer run of each harness (clang, ASan + UBSan; see README "Fuzzing and sanitizers").
bash scripts/fuzz.sh 10
