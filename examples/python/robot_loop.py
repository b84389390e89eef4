#!/usr/bin/env python3
"""moa.Odometry in a robot's loop (docs/python.md): a log's mice rows fed in
real time, one push per row as a driver would hand them over, and the time
from each row's arrival to the step it completes, median and 99th percentile
on the monotonic clock.

    PYTHONPATH=build/python python3 examples/python/robot_loop.py LOG_DIR [--seconds 5]

LOG_DIR holds robot.yaml and mice.csv (`moa bench --replay --keep-log` writes
one with four sensors at 1 kHz).
"""
import argparse
import os
import time

import moa


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("log", help="log directory (robot.yaml, mice.csv)")
    parser.add_argument("--seconds", type=float, default=5.0, help="seconds of log to feed")
    parser.add_argument("--rate", type=float, default=1000.0, help="epochs per second")
    args = parser.parse_args()

    config = os.path.join(args.log, "robot.yaml")
    mice = moa.read_log(config, args.log)["mice"]
    t, sensor, dx, dy = (mice[k].tolist() for k in ("t", "sensor", "dx", "dy"))
    odo = moa.Odometry(config, t0=t[0], estimator="consensus", rate=args.rate)

    latency = []  # s, per push that completed steps
    total = 0  # steps
    start = time.monotonic()
    for k in range(len(t)):
        if t[k] - t[0] > args.seconds:
            break
        # The row arrives at its time, as from a device.
        due = start + (t[k] - t[0])
        while (now := time.monotonic()) < due:
            time.sleep(min(due - now, 0.0005))
        arrival = time.monotonic()
        steps = odo.push(t[k], sensor[k], dx[k], dy[k])
        if len(steps["t"]) > 0:
            pose = (steps["x"][-1], steps["y"][-1], steps["theta"][-1])  # what a robot would use
            latency.append(time.monotonic() - arrival)
            total += len(steps["t"])
    latency.sort()
    n = len(latency)
    p50 = latency[(n + 1) // 2 - 1]
    p99 = latency[-(-99 * n // 100) - 1]
    print(
        f"{total} steps at {args.rate:g} Hz, completed by {n} pushes; from such a row's arrival to "
        f"its steps returned, "
        f"p50 {1e6 * p50:.1f} us, p99 {1e6 * p99:.1f} us, max {1e6 * latency[-1]:.1f} us; "
        f"last pose x {pose[0]:+.4f} m, y {pose[1]:+.4f} m, theta {pose[2]:+.4f} rad"
    )


if __name__ == "__main__":
    main()
