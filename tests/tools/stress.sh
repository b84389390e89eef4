#!/usr/bin/env bash
# The suite under load: the whole ctest of a build, RUNS times in a row,
# with BUSY busy processes beside it (one per core by default: the machine
# is loaded as CI's parallel ctest loads it, and more). Prints every test
# that failed at least once with its failure rate, as a Markdown table, and
# exits 1 if any did (docs/reliability.md, "Tests under load").
#
#   tests/tools/stress.sh [-n RUNS] [-b BUILD_DIR] [-l BUSY] [-j JOBS] [-R REGEX] [-E REGEX]
#
# -n 10 runs, -b build, -l nproc busy loops, -j nproc ctest jobs; -R / -E
# select tests as ctest's own flags do. Each run's log is kept in
# BUILD_DIR/stress/run-K.log.
set -euo pipefail

runs=10
build=build
busy=$(nproc)
jobs=$(nproc)
select=()
usage() { sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; }
while getopts "n:b:l:j:R:E:h" opt; do
  case $opt in
    n) runs=$OPTARG ;;
    b) build=$OPTARG ;;
    l) busy=$OPTARG ;;
    j) jobs=$OPTARG ;;
    R) select+=(-R "$OPTARG") ;;
    E) select+=(-E "$OPTARG") ;;
    h) usage; exit 0 ;;
    *) usage >&2; exit 2 ;;
  esac
done
for n in "$runs" "$busy" "$jobs"; do
  [[ $n =~ ^[0-9]+$ ]] || { echo "stress.sh: '$n' is not a count" >&2; exit 2; }
done
[[ -f $build/CTestTestfile.cmake ]] || {
  echo "stress.sh: $build has no tests (build it first: make build, or -b DIR)" >&2
  exit 2
}

out=$build/stress
mkdir -p "$out"
pids=()
stop_load() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; }
trap stop_load EXIT
for ((k = 0; k < busy; ++k)); do
  (while :; do :; done) &
  pids+=($!)
done

declare -A failed=()
total=0
start=$(date +%s)
for ((r = 1; r <= runs; ++r)); do
  log=$out/run-$r.log
  t0=$(date +%s)
  (cd "$build" && ctest -j "$jobs" --output-on-failure "${select[@]}") >"$log" 2>&1 || true
  count=$(sed -n 's/.*tests passed, [0-9]* tests failed out of \([0-9]*\).*/\1/p' "$log" | tail -1)
  [[ -n $count ]] || { echo "stress.sh: run $r printed no ctest summary (see $log)" >&2; exit 2; }
  total=$count
  names=$(sed -n '/The following tests FAILED:/,$p' "$log" |
    sed -n 's/^[[:space:]]*[0-9]* - \([^ ]*\) .*/\1/p')
  n=0
  for name in $names; do
    failed[$name]=$((${failed[$name]:-0} + 1))
    n=$((n + 1))
  done
  echo "stress.sh: run $r of $runs: $n of $total tests failed ($(($(date +%s) - t0)) s)"
done

echo
echo "$runs runs of $total tests, $busy busy processes beside ctest -j $jobs," \
  "$(nproc) cores, $(($(date +%s) - start)) s"
echo
if ((${#failed[@]} == 0)); then
  echo "no test failed"
  exit 0
fi
echo "| test | failed | rate |"
echo "|---|---|---|"
for name in "${!failed[@]}"; do
  echo "| $name | ${failed[$name]} of $runs | $((100 * ${failed[$name]} / runs)) % |"
done | sort
exit 1
