#!/bin/bash
# Byte comparison of two moa binaries' `moa odometry` on the same inputs:
# odometry.csv, the --self-calibration CSV, stdout, stderr and the exit code
# of each run must be identical (a performance change must not move a bit).
#
#   tests/tools/compare_odometry.sh OLD_MOA NEW_MOA [WORK_DIR] [SYNTH_LOG]
#
# Inputs: every log under examples/logs/ with every estimator at 100 Hz and
# 1 kHz; `moa simulate` (by OLD_MOA) of faults-dirty, sekimori-b,
# faults-drift and faults-stuck, seeds 1 and 2, with consensus at 100 Hz and
# 1 kHz, --fuse-camera, --fuse-camera --ekf-scale, --self-calibrate,
# --self-calibration FILE.csv, --no-motion-prior, --sensors m1,m2,m3, and
# all estimators on two of them; with SYNTH_LOG (build/tests/synth_log), a
# 60 s 1 kHz log with ls, sekimori and consensus. Prints the runs that differ
# and exits 1 if any does.
set -u
if [ $# -lt 2 ]; then
  sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//'
  exit 2
fi
OLD=$(realpath "$1")
NEW=$(realpath "$2")
WORK=${3:-$(mktemp -d)}
SYNTH=${4:-}
SOURCE=$(cd "$(dirname "$0")/../.." && pwd)
mkdir -p "$WORK/logs"
L=$WORK/logs
W=$WORK/run
fail=0
n=0

run() {  # name, log directory, options...
  local name=$1 log=$2
  shift 2
  local b bin
  for b in old new; do
    bin=$OLD
    [ $b = new ] && bin=$NEW
    rm -rf "$W/$b"
    mkdir -p "$W/$b"
    rm -f "$W/out.csv" "$W/sc.csv"
    (cd "$W" && "$bin" odometry --config "$log/robot.yaml" --log "$log" --out "$W/out.csv" "$@" \
      > "$W/$b/stdout" 2> "$W/$b/stderr"; echo $? > "$W/$b/rc")
    [ -f "$W/out.csv" ] && mv "$W/out.csv" "$W/$b/out.csv"
    [ -f "$W/sc.csv" ] && mv "$W/sc.csv" "$W/$b/sc.csv"
  done
  n=$((n + 1))
  local f
  for f in stdout stderr rc out.csv sc.csv; do
    if [ -e "$W/old/$f" ] || [ -e "$W/new/$f" ]; then
      if ! cmp -s "$W/old/$f" "$W/new/$f"; then
        echo "DIFF $name: $f"
        fail=1
      fi
    fi
  done
}

mkdir -p "$W"
for log in "$SOURCE"/examples/logs/*/; do
  log=${log%/}
  for e in ls sekimori consensus wheels oracle; do
    run "$(basename "$log") $e" "$log" --estimator "$e"
    run "$(basename "$log") $e 1k" "$log" --estimator "$e" --rate 1000
  done
  run "$(basename "$log") no-motion-prior" "$log" --no-motion-prior
  run "$(basename "$log") self-calibrate" "$log" --self-calibrate
done
for s in faults-dirty sekimori-b faults-drift faults-stuck; do
  for seed in 1 2; do
    d=$L/$s-$seed
    [ -d "$d" ] || "$OLD" simulate --scenario "$s" --seed "$seed" --out "$d" --quiet
    run "$s-$seed consensus" "$d" --estimator consensus
    run "$s-$seed consensus 1k" "$d" --estimator consensus --rate 1000
    run "$s-$seed fuse-camera" "$d" --fuse-camera
    run "$s-$seed ekf-scale" "$d" --fuse-camera --ekf-scale
    run "$s-$seed self-calibrate" "$d" --self-calibrate
    run "$s-$seed self-calibration" "$d" --self-calibration "$W/sc.csv"
    run "$s-$seed no-motion-prior" "$d" --no-motion-prior
    run "$s-$seed sensors" "$d" --sensors m1,m2,m3
  done
done
for e in ls sekimori consensus oracle wheels; do
  run "faults-dirty-1 $e" "$L/faults-dirty-1" --estimator "$e"
  run "faults-stuck-2 $e" "$L/faults-stuck-2" --estimator "$e"
done
if [ -n "$SYNTH" ]; then
  [ -d "$L/long60" ] || "$SYNTH" "$L/long60" 60 0.001 > /dev/null
  for e in ls sekimori consensus; do
    run "long60 $e 1k" "$L/long60" --estimator "$e" --rate 1000
  done
  run "long60 consensus" "$L/long60"
  run "long60 self-calibrate 1k" "$L/long60" --rate 1000 --self-calibrate
fi
echo "$n runs compared, $([ $fail = 0 ] && echo all identical || echo some differ)"
exit $fail
