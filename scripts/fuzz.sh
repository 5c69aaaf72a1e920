#!/usr/bin/env bash
# Fuzzing: builds the libFuzzer harnesses of fuzz/ (clang, ASan + UBSan) in build-fuzz, then runs
# each for SECONDS (default 60) on a copy of its seed corpus (fuzz/corpus/NAME), with WORKERS
# parallel jobs (default 1). A finding stops that harness, is saved to build-fuzz/findings/NAME/
# and fails the script. Usage: bash scripts/fuzz.sh [SECONDS] [WORKERS] [NAME...]
# Each harness runs in its own directory (build-fuzz/run/NAME), where libFuzzer writes its
# per-worker fuzz-N.log, so two invocations on different harnesses can run at once.
set -euo pipefail
cd "$(dirname "$0")/.."
SECS=${1:-60}
WORKERS=${2:-1}
shift $(( $# > 2 ? 2 : $# ))
NAMES=("$@")
[ ${#NAMES[@]} -gt 0 ] || NAMES=(pcd ply xyz las pipeline_json rig_yaml capture_image)
bash scripts/setup.sh
mkdir -p build-fuzz
CC=clang CXX=clang++ cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DHEDGEFIT_BUILD_FUZZ=ON \
  -DHEDGEFIT_BUILD_TESTS=OFF -DHEDGEFIT_BUILD_BENCH=OFF -DHEDGEFIT_WERROR=OFF > build-fuzz/build.log
cmake --build build-fuzz -j2 --target $(printf 'fuzz_%s ' "${NAMES[@]}") >> build-fuzz/build.log
status=0
for n in "${NAMES[@]}"; do
  mkdir -p build-fuzz/corpus/$n build-fuzz/findings/$n
  cp -n fuzz/corpus/$n/* build-fuzz/corpus/$n/ 2>/dev/null || true
  log=$PWD/build-fuzz/findings/$n.log
  run=$PWD/build-fuzz/run/$n
  rm -rf "$run" && mkdir -p "$run"
  # OpenCV and libpng print warnings for broken images: those are expected, not findings.
  cpu0=$(awk '{print $14 + $15 + $16 + $17}' /proc/$$/stat)
  if (cd "$run" && ../../fuzz/fuzz_$n ../../corpus/$n -max_total_time=$SECS -jobs=$WORKERS -workers=$WORKERS \
       -artifact_prefix=../../findings/$n/ -timeout=20 -rss_limit_mb=4096 -max_len=65536 \
       -print_final_stats=1 > $log 2>&1); then
    runs=$(grep -h "stat::number_of_executed_units" $log "$run"/fuzz-*.log 2>/dev/null | awk '{s += $2} END {print s + 0}')
    # CPU time of the finished children (user + system), in minutes.
    cpu=$(awk -v c0=$cpu0 -v hz=$(getconf CLK_TCK) '{printf "%.1f", ($14 + $15 + $16 + $17 - c0) / hz / 60}' /proc/$$/stat)
    echo "fuzz_$n: $runs inputs in ${SECS} s x $WORKERS workers ($cpu CPU-minutes), no finding"
  else
    echo "fuzz_$n: FINDING, see $log and build-fuzz/findings/$n/" >&2
    grep -m5 -E "ERROR|SUMMARY|runtime error" $log >&2 || tail -5 $log >&2
    status=1
  fi
done
exit $status
