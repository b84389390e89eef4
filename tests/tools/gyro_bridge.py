#!/usr/bin/env python3
"""Issue #29's baseline: bridge a log's common-mode dropouts with the gyro.

Usage: gyro_bridge.py ODOMETRY.csv LOG_DIR [--true]

ODOMETRY.csv is `moa odometry --estimator oracle --no-imu`'s output: the
array's twist outside the dropouts and the wheels' in them (source column
not `mice`). Here each epoch whose source is not `mice` takes its rotation
from LOG_DIR/imu.csv instead: the reading of the row whose interval ends at
the epoch's end (row t minus the gyro's latency), calibrated with
robot.yaml's imu scale and bias, or robot.true.yaml's with --true. The
twists are integrated with the SE(2) exponential per epoch from the truth's
first pose, and the max translation (mm) and heading (deg) errors against
LOG_DIR/truth.csv at the odometry's epochs are printed.
"""
import csv
import math
import sys


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def imu_block(path):
    """The numbers of robot.yaml's top-level `imu:` block (as moa writes it)."""
    block, inside = {}, False
    for line in open(path):
        if line.startswith("imu:"):
            inside = True
        elif inside and line.startswith("  ") and ":" in line:
            key, value = line.split("#")[0].split(":", 1)
            block[key.strip()] = float(value)
        elif inside and line.strip():
            break
    return block


def main():
    args = [a for a in sys.argv[1:] if a != "--true"]
    if len(args) != 2:
        sys.exit(__doc__)
    odometry, log = args
    imu = imu_block(f"{log}/robot{'.true' if '--true' in sys.argv else ''}.yaml")
    scale, bias, latency = imu.get("scale", 1.0), imu.get("bias", 0.0), imu.get("latency", 0.0)
    gyro = {round(float(r["t"]) - latency, 3): float(r["gz"]) for r in rows(f"{log}/imu.csv")}
    truth = {round(float(r["t"]), 2): r for r in rows(f"{log}/truth.csv")}
    epochs = rows(odometry)
    first = truth[round(float(epochs[0]["t"]), 2)]
    x, y, th = float(first["x"]), float(first["y"]), float(first["theta"])
    last, worst_mm, worst_deg, bridged = None, 0.0, 0.0, 0
    for r in epochs:
        t = float(r["t"])
        if last is not None:
            dt = t - last
            vx, vy, w = float(r["vx"]), float(r["vy"]), float(r["omega"])
            if r["source"] != "mice":
                w = (gyro[round(t, 3)] - bias) / scale
                bridged += 1
            a = w * dt
            s, c = (1.0, 0.0) if abs(a) < 1e-9 else (math.sin(a) / a, (1 - math.cos(a)) / a)
            dx, dy = (s * vx - c * vy) * dt, (c * vx + s * vy) * dt
            x += math.cos(th) * dx - math.sin(th) * dy
            y += math.sin(th) * dx + math.cos(th) * dy
            th += a
        last = t
        q = truth.get(round(t, 2))
        if q is not None:
            worst_mm = max(worst_mm, 1e3 * math.hypot(x - float(q["x"]), y - float(q["y"])))
            d = math.remainder(th - float(q["theta"]), 2 * math.pi)
            worst_deg = max(worst_deg, abs(math.degrees(d)))
    print(f"{bridged} epochs bridged with the gyro: max translation error {worst_mm:.1f} mm, "
          f"max heading error {worst_deg:.2f} deg")


if __name__ == "__main__":
    main()
