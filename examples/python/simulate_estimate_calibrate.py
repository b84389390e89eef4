#!/usr/bin/env python3
"""Simulates a robot, estimates its path, calibrates its sensors, plots.

    PYTHONPATH=build/python python3 examples/python/simulate_estimate_calibrate.py --out /tmp/moa-py

1. simulates the built-in 'calibration' scenario (four sensors mounted a few
   mm and degrees off their nominal config) and writes the log;
2. estimates the path with the nominal config, then calibrates the mounts
   against wheels.csv (method exact) and estimates again with the result;
3. plots truth and both estimates, the position error over time and the
   sensors' nominal, calibrated and true positions to OUT/moa_example.png.
"""
import argparse
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import moa  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=pathlib.Path, required=True, help="output directory")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    log = args.out / "log"
    sim = moa.simulate("calibration", args.seed, out=log)
    truth = sim["truth"]

    nominal = moa.odometry(log / "robot.yaml", log, "consensus")
    cal = moa.calibrate(log / "robot.yaml", log, method="exact")
    print(cal.brief_report())
    calibrated_yaml = args.out / "calibrated.yaml"
    calibrated_yaml.write_text(cal.to_yaml())
    calibrated = moa.odometry(calibrated_yaml, log, "consensus")

    errors = {}
    for label, run in [("nominal config", nominal), ("calibrated config", calibrated)]:
        e = moa.evaluate(truth, run)
        errors[label] = e
        print(f"{label:18s} max translation error {e['max_translation_m'] * 1e3:7.2f} mm, "
              f"max heading error {np.degrees(e['max_heading_rad']):6.3f} deg")

    fig, (ax_path, ax_err, ax_mounts) = plt.subplots(1, 3, figsize=(16, 5))
    ax_path.plot(truth["x"], truth["y"], "-", color="0.6", lw=4, label="truth")
    for label, run, style in [("nominal config", nominal, "r--"),
                              ("calibrated config", calibrated, "b-")]:
        ax_path.plot(run["x"], run["y"], style, lw=1, label=label)
    ax_path.set(xlabel="x (m)", ylabel="y (m)", title="path (world frame)")
    ax_path.axis("equal")
    ax_path.legend()

    for label, run, style in [("nominal config", nominal, "r-"),
                              ("calibrated config", calibrated, "b-")]:
        x = np.interp(run["t"], truth["t"], truth["x"])
        y = np.interp(run["t"], truth["t"], truth["y"])
        ax_err.plot(run["t"], np.hypot(run["x"] - x, run["y"] - y) * 1e3, style, label=label)
    ax_err.set(xlabel="t (s)", ylabel="position error (mm)", title="error against truth")
    ax_err.legend()

    true_mounts = sim["true_config"].to_dict()
    for i, s in enumerate(cal.sensors):
        n, c, t = s["nominal"]["position"], s["position"], true_mounts["position"][i]
        ax_mounts.plot(*(n * 1e3), "rs", ms=8, label="nominal" if i == 0 else None)
        ax_mounts.plot(*(t * 1e3), "ko", ms=10, mfc="none", label="true" if i == 0 else None)
        ax_mounts.plot(*(c * 1e3), "b+", ms=12, label="calibrated" if i == 0 else None)
        ax_mounts.annotate(s["name"], n * 1e3, textcoords="offset points", xytext=(6, 6))
    ax_mounts.set(xlabel="x (mm, robot frame)", ylabel="y (mm)", title="sensor positions")
    ax_mounts.axis("equal")
    ax_mounts.legend()

    fig.tight_layout()
    png = args.out / "moa_example.png"
    fig.savefig(png, dpi=90)
    print(f"plot written to {png}")
    # The calibrated mounts must make dead reckoning better, or the example says so.
    if errors["calibrated config"]["max_translation_m"] >= errors["nominal config"][
            "max_translation_m"]:
        raise SystemExit("calibration did not reduce the translation error")


if __name__ == "__main__":
    main()
