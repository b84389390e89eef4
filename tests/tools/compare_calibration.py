#!/usr/bin/env python3
# Usage: compare_calibration.py CALIBRATED.yaml TRUE.yaml NOMINAL.yaml [--gauge]
# Errors of a calibrated config against the simulator's robot.true.yaml:
# position (mm), yaw (deg), scale (%), sensor latency (ms) per sensor, the
# camera latency (ms). --gauge: positions only (a ceiling camera) sees the
# robot frame up to a turn; the truth is turned back by the circular mean of
# its yaw changes from NOMINAL over the sensors whose mirroring is nominal's,
# the gauge moa calibrate keeps (docs/calibration.md, "Positions only").
# Latencies are compared relative to the sensors' mean (the calibration's
# gauge keeps the configured mean).
import math, sys, yaml

cal, true, nom = (yaml.safe_load(open(p)) for p in sys.argv[1:4])
gauge = "--gauge" in sys.argv[4:]
wrap = lambda a: math.atan2(math.sin(a), math.cos(a))
delta = 0.0
if gauge:
    s = c = 0.0
    for t, n in zip(true["sensors"], nom["sensors"]):
        if t.get("mirrored", False) == n.get("mirrored", False):
            s += math.sin(wrap(t["yaw"] - n["yaw"]))
            c += math.cos(wrap(t["yaw"] - n["yaw"]))
    delta = math.atan2(s, c)
cd, sd = math.cos(-delta), math.sin(-delta)
mean = lambda xs: sum(xs) / len(xs)
lat_c = [x.get("latency", 0.0) for x in cal["sensors"]]
lat_t = [x.get("latency", 0.0) for x in true["sensors"]]
worst = [0.0] * 4
print("sensor  position_mm  yaw_deg  scale_%  latency_ms")
for k, (a, t) in enumerate(zip(cal["sensors"], true["sensors"])):
    px, py = t["position"]
    tx, ty = cd * px - sd * py, sd * px + cd * py
    e = [1e3 * math.hypot(a["position"][0] - tx, a["position"][1] - ty),
         math.degrees(abs(wrap(a["yaw"] - (t["yaw"] - delta)))),
         100 * max(abs(a["scale"][i] - t["scale"][i]) for i in range(2)),
         1e3 * abs((lat_c[k] - mean(lat_c)) - (lat_t[k] - mean(lat_t)))]
    worst = [max(w, x) for w, x in zip(worst, e)]
    print(f"{t['name']:6} {e[0]:12.3f} {e[1]:8.4f} {e[2]:8.3f} {e[3]:11.3f}")
cam = 1e3 * ((cal.get("camera", {}).get("latency", 0.0) - mean(lat_c))
             - (true.get("camera", {}).get("latency", 0.0) - mean(lat_t)))
print(f"worst  {worst[0]:12.3f} {worst[1]:8.4f} {worst[2]:8.3f} {worst[3]:11.3f}")
print(f"camera latency error (relative to the sensors' mean) {cam:+.3f} ms")
