#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, ASan, UBSan) in build-fuzz/ and runs
# each for SECONDS (default 60), JOBS at a time (default 2), from its seed
# corpus tests/fuzz/<target>/; new inputs go to build-fuzz/corpus/<target>/,
# findings to build-fuzz/findings/. Exits non-zero if any target found one.
# FUZZ_BUILD_DIR names another build directory; one already configured with
# MOA_BUILD_FUZZERS=ON (CI's sanitizer build) is used as it is, not
# configured again.
#   tests/fuzz/run.sh [SECONDS [TARGET...]]
set -euo pipefail
cd "$(dirname "$0")/../.."
seconds=${1:-60}
shift || true
jobs=${JOBS:-2}
build=${FUZZ_BUILD_DIR:-build-fuzz}
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  targets=(fuzz_mice_csv fuzz_wheels_csv fuzz_camera_csv fuzz_truth_csv fuzz_config
           fuzz_scenario fuzz_evemu fuzz_serial fuzz_evdev fuzz_stream_lines fuzz_otos)
fi

if ! grep -qs '^MOA_BUILD_FUZZERS:BOOL=ON$' "$build/CMakeCache.txt"; then
  CC=clang CXX=clang++ cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DMOA_BUILD_FUZZERS=ON -DMOA_BUILD_TESTS=OFF -DMOA_BUILD_BENCHMARKS=OFF \
    -DMOA_BUILD_EXAMPLES=OFF -DMOA_BUILD_FIRMWARE=OFF -DMOA_BUILD_EMBEDDED=OFF >/dev/null
fi
cmake --build "$build" -j "$(nproc)" --target "${targets[@]}"

run_one() {
  local target=$1
  local corpus="$build/corpus/$target" findings="$build/findings/$target"
  mkdir -p "$corpus" "$findings"
  # -rss_limit_mb: a reader whose memory grows without bound is a finding;
  # -timeout: so is one input taking more than 10 s.
  if "$build/tests/fuzz/$target" "$corpus" "tests/fuzz/$target" -max_total_time="$seconds" \
      -rss_limit_mb=2048 -timeout=10 -max_len=65536 -artifact_prefix="$findings/" \
      -print_final_stats=1 >"$build/$target.log" 2>&1; then
    echo "$target: $(grep -m1 '^stat::number_of_executed_units' "$build/$target.log" |
      awk '{print $2}') executions, no finding"
  else
    echo "$target: FINDING, see $build/$target.log and $findings/"
    tail -n 30 "$build/$target.log"
    return 1
  fi
}

failed=0
running=0
for target in "${targets[@]}"; do
  run_one "$target" &
  running=$((running + 1))
  if [ "$running" -ge "$jobs" ]; then
    wait -n || failed=1
    running=$((running - 1))
  fi
done
while [ "$running" -gt 0 ]; do
  wait -n || failed=1
  running=$((running - 1))
done
exit "$failed"
