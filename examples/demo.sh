#!/bin/sh
# make demo, after the build: dead reckoning on the example log and on a
# simulated run, each judged against its truth, then a report page; ends by
# saying what was shown, with the numbers just computed.
#   sh examples/demo.sh MOA OUT_DIR
set -eu
moa=$1
out=$2
mkdir -p "$out"
log=examples/logs/mixed-motion
sim=$out/sekimori-b

echo
echo "== 1. A clean log ($log): four sensors with yaw, scale and mirroring, integer counts, no noise"
"$moa" odometry --config $log/robot.yaml --log $log --estimator ls --out "$out/odometry.csv"
"$moa" evaluate --config $log/robot.yaml --truth $log/truth.csv --odometry "$out/odometry.csv" |
  tee "$out/evaluate.txt"

echo
echo "== 2. Sekimori & Miyazaki's path (Table 3) at 0.5 m/s, simulated: sensors that lose track,"
echo "      mounts 0.2 mm off, the consensus estimator"
rm -rf "$sim"  # simulate writes only into an empty directory or over its own run
"$moa" simulate --scenario sekimori-b --seed 1 --out "$sim"
"$moa" odometry --config "$sim/robot.yaml" --log "$sim" --estimator consensus --out "$sim/odometry.csv"
"$moa" evaluate --config "$sim/robot.yaml" --truth "$sim/truth.csv" --odometry "$sim/odometry.csv" |
  tee "$sim/evaluate.txt"
"$moa" report --config "$sim/robot.yaml" --log "$sim" --odometry "$sim/odometry.csv" \
  --truth "$sim/truth.csv" --title "moa demo: Sekimori & Miyazaki's path, simulated (seed 1)" \
  --out "$sim/report.html"

# The figures of each run, from what moa evaluate printed above.
max_error() { sed -n 's/^translation error *max \(.*\), rms.*/\1/p' "$1"; }
verdict() { sed -n 's/^verdict *//p' "$1"; }
faulty=$(awk -F, 'NR > 2 && $3 != 0 { n++ } END { print n + 0 }' "$sim/faults.csv")
rows=$(awk 'NR > 2 { n++ } END { print n + 0 }' "$sim/faults.csv")
echo
echo "== What this showed"
echo "1. The clean log: max error $(max_error "$out/evaluate.txt"),"
echo "   $(verdict "$out/evaluate.txt")."
echo "2. Sekimori & Miyazaki's path with $faulty of $rows sensor rows faulty: the consensus stays"
echo "   within $(max_error "$sim/evaluate.txt"),"
echo "   $(verdict "$sim/evaluate.txt")."
echo "The report page of run 2: file://$(cd "$sim" && pwd)/report.html"
