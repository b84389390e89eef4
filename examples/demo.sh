#!/bin/sh
# make demo, after the build: dead reckoning on the example log and on a
# simulated run, each evaluated against its truth, and a report page.
#   sh examples/demo.sh MOA OUT_DIR
set -eu
moa=$1
out=$2
mkdir -p "$out"
log=examples/logs/mixed-motion

echo
echo "1. A clean log ($log): four sensors, integer counts, no noise"
"$moa" odometry --config $log/robot.yaml --log $log --estimator ls --out "$out/odometry.csv"
"$moa" evaluate --config $log/robot.yaml --truth $log/truth.csv --odometry "$out/odometry.csv"

sim=$out/sekimori-b
echo
echo "2. A simulated run of Sekimori & Miyazaki's path at 0.5 m/s, sensors that lose track"
"$moa" simulate --scenario sekimori-b --seed 1 --out "$sim"
"$moa" odometry --config "$sim/robot.yaml" --log "$sim" --estimator consensus --out "$sim/odometry.csv"
"$moa" evaluate --config "$sim/robot.yaml" --truth "$sim/truth.csv" --odometry "$sim/odometry.csv"
"$moa" report --config "$sim/robot.yaml" --log "$sim" --odometry "$sim/odometry.csv" \
  --truth "$sim/truth.csv" --out "$sim/report.html"
