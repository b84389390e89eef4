"""The Python module against the `moa` command: same numbers, same selection,
same calibrated config, same error messages (the command is run here, on
logs it simulates)."""
import ast
import csv
import json
import os
import pathlib
import re
import subprocess

import numpy as np
import pytest

import moa  # a missing module fails the collection: pytest exits non-zero

MOA = os.environ.get("MOA_CLI", "moa")
NUMERIC = ["t", "x", "y", "theta", "vx", "vy", "omega", "sd_vx", "sd_vy", "sd_omega"]


def run(*args):
    """Runs the command; returns (exit code, stdout, stderr)."""
    r = subprocess.run([MOA, *map(str, args)], capture_output=True, text=True)
    return r.returncode, r.stdout, r.stderr


def cli_error(subcommand, *args):
    code, _, err = run(subcommand, *args)
    assert code != 0
    prefix = f"moa {subcommand}: error: "
    assert err.startswith(prefix), err
    return err[len(prefix):].rstrip("\n")


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    root = tmp_path_factory.mktemp("logs")
    out = {}
    for scenario, seed in [("calibration", 4), ("faults-liftoff", 2)]:
        d = root / scenario
        code, _, err = run("simulate", "--scenario", scenario, "--seed", seed, "--out", d,
                           "--quiet")
        assert code == 0, err
        out[scenario] = d
    return out


def read_csv(path):
    with open(path, newline="") as f:
        rows = [r for r in csv.reader(line for line in f if not line.startswith("#"))]
    header, rows = rows[0], rows[1:]
    return {name: [r[i] for r in rows] for i, name in enumerate(header)}


def assert_equals_cli(py, csv_path):
    """moa.odometry's dict equals the CSV: numbers to 1e-9, selection exactly."""
    f = read_csv(csv_path)
    assert len(py["t"]) == len(f["t"]) > 0
    columns = NUMERIC + [c for c in ("pxx", "pxy", "pyy", "ptt", "scale_v", "scale_omega",
                                      "sd_scale_v", "sd_scale_omega") if c in f]
    for c in columns:
        np.testing.assert_allclose(py[c], np.array(f[c], dtype=float), rtol=0, atol=1e-9,
                                   err_msg=c)
    assert list(py["source"]) == f["source"]
    names = py["names"]
    used = ["+".join(n for n, u in zip(names, row) if u) for row in py["used"]]
    excluded = [";".join(f"{n}:{e}" for n, u, e in zip(names, urow, erow) if not u)
                for urow, erow in zip(py["used"], py["excluded"])]
    assert used == f["used"]
    assert excluded == f["excluded"]


@pytest.mark.parametrize("scenario,estimator,flags,options", [
    ("calibration", "consensus", [], {}),
    ("calibration", "ls", ["--rate", "50", "--no-wheels"], {"rate": 50, "no_wheels": True}),
    ("faults-liftoff", "consensus", [], {}),
    ("faults-liftoff", "sekimori", ["--e-th", "1e-7", "--r-th", "1"], {"e_th": 1e-7, "r_th": 1}),
    ("faults-liftoff", "consensus", ["--sensors", "m1,m3", "--alpha", "0.01"],
     {"sensors": ["m1", "m3"], "alpha": 0.01}),
    ("faults-liftoff", "consensus",
     ["--fuse-camera", "--camera-latency", "0.02", "--camera-sigma", "0.01",
      "--initial-pose", "0.1,-0.2,0.3"],
     {"fuse_camera": True, "camera_latency": 0.02, "camera_sigma": 0.01,
      "initial_pose": (0.1, -0.2, 0.3)}),
    ("faults-liftoff", "consensus", ["--fuse-camera", "--camera-latency", "0.1", "--ekf-scale"],
     {"fuse_camera": True, "camera_latency": 0.1, "ekf_scale": True}),
    ("faults-liftoff", "oracle", ["--max-row-interval", "0.04", "--max-gap", "10"],
     {"max_row_interval": 0.04, "max_gap": 10}),
    # The default row interval follows the rate as the command's does (0.05 s
    # would be 250 epochs at 5000 Hz, beyond the synchroniser's 61).
    ("calibration", "consensus", ["--rate", "5000"], {"rate": 5000}),
])
def test_odometry_equals_the_command(logs, tmp_path, scenario, estimator, flags, options):
    d = logs[scenario]
    out = tmp_path / "odometry.csv"
    code, _, err = run("odometry", "--config", d / "robot.yaml", "--log", d, "--estimator",
                       estimator, *flags, "--out", out)
    assert code == 0, err
    py = moa.odometry(d / "robot.yaml", d, estimator, **options)
    assert_equals_cli(py, out)


def test_faults_scenario_exercises_the_selection_columns(logs):
    py = moa.odometry(logs["faults-liftoff"] / "robot.yaml", logs["faults-liftoff"])
    assert not py["used"].all()
    assert (py["excluded"] != "").any()


def test_odometry_summary_counts_are_the_columns(logs):
    py = moa.odometry(logs["faults-liftoff"] / "robot.yaml", logs["faults-liftoff"])
    s = py["summary"]
    assert s.epochs == len(py["t"])
    sources = list(py["source"])
    assert s.epochs_by_source == {k: sources.count(k) for k in ("mice", "wheels", "hold")}
    counted = {"used": int(py["used"].sum())}
    for row_used, row_excluded in zip(py["used"], py["excluded"]):
        for u, e in zip(row_used, row_excluded):
            if not u:
                reason = e.split("/")[0]
                counted[reason] = counted.get(reason, 0) + 1
    assert {k: v for k, v in s.sensor_epochs.items() if v} == counted
    held = s.epochs_by_source["hold"]
    assert s.usable == (s.epochs > 0 and held <= 0.01 * s.epochs)
    assert s.verdict() in s.text()


def test_odometry_gyro_summary_and_heading_are_those_of_diagnostics_csv(tmp_path):
    """gyro-bump has imu.csv: the heading column and the summary's gyro fields
    against the imu rows of the command's diagnostics.csv (fused = 1: the
    epoch's heading was the gyro's)."""
    log = tmp_path / "gyro"
    code, _, err = run("simulate", "--scenario", "gyro-bump", "--seed", 101, "--out", log,
                       "--quiet")
    assert code == 0, err
    diagnostics = tmp_path / "diagnostics.csv"
    code, out, err = run("odometry", "--config", log / "robot.yaml", "--log", log, "--out",
                         tmp_path / "odometry.csv", "--diagnostics", diagnostics)
    assert code == 0, err
    with open(diagnostics, newline="") as f:
        imu = [r for r in csv.DictReader(f) if r["source"] == "imu"]
    fused = sum(r["fused"] == "1" for r in imu)
    assert fused > 0
    py = moa.odometry(log / "robot.yaml", log)
    s = py["summary"]
    assert s.heading_from_gyro == fused
    assert s.gyro_epochs == len(imu)
    assert list(py["heading"]).count("gyro") == fused
    # Not the gyro's: the twist's source.
    other = py["heading"] != "gyro"
    assert (py["heading"][other] == py["source"][other]).all()
    # A test ratio where diagnostics.csv has one.
    tested = [r["test_ratio"] for r in imu if r["test_ratio"] != ""]
    assert int(np.isfinite(py["gyro_test"]).sum()) == len(tested)
    np.testing.assert_allclose(np.sort(py["gyro_test"][np.isfinite(py["gyro_test"])]),
                               np.sort(np.array(tested, dtype=float)), rtol=1e-12)
    # The calibration: the simulated gyro's (bias 0.01 rad/s, scale 1.02)
    # within a few sd, as `moa odometry` printed it.
    g = s.gyro
    assert set(g) == {"bias", "bias_sd", "scale", "scale_sd", "latency", "latency_sd"}
    assert abs(g["bias"] - 0.01) < 4 * g["bias_sd"] + 1e-3
    assert abs(g["scale"] - 1.02) < 4 * g["scale_sd"] + 5e-3
    assert f"gyro: bias {g['bias']:.5f} rad/s" in out
    # diagnostics.csv's last imu row: the same calibration, to the digit.
    assert abs(float(imu[-1]["bias"]) - g["bias"]) <= 1e-12
    assert abs(float(imu[-1]["scale"]) - g["scale"]) <= 1e-12
    assert f"heading from the gyro in {fused} of {s.epochs} epochs" in out
    # no_imu: the rotation is the array's.
    bare = moa.odometry(log / "robot.yaml", log, no_imu=True)
    assert bare["summary"].gyro is None
    assert bare["summary"].heading_from_gyro == 0
    assert "gyro" not in set(bare["heading"])
    assert np.isnan(bare["gyro_test"]).all()


def test_odometry_object_in_bulk_and_row_by_row_equals_the_file_pipeline(logs):
    d = logs["calibration"]
    expected = moa.odometry(d / "robot.yaml", d, "ls", no_wheels=True)
    rows = moa.read_log(d / "robot.yaml", d)["mice"]
    bulk = moa.Odometry(d / "robot.yaml", t0=rows["t"][0], estimator="ls", no_wheels=True)
    steps = [bulk.push_rows(rows["t"], rows["sensor"], rows["dx"], rows["dy"], rows["squal"],
                            rows["flags"])]
    steps.append(bulk.finish(rows["t"][-1]))
    for c in NUMERIC:
        np.testing.assert_array_equal(np.concatenate([s[c] for s in steps]), expected[c])
    assert bulk.steps == len(expected["t"])

    one = moa.Odometry(moa.Config(d / "robot.yaml"), t0=rows["t"][0], estimator="ls",
                       no_wheels=True)
    names = one.names
    got = []
    for k in range(2000):
        s = one.push(rows["t"][k], names[rows["sensor"][k]], rows["dx"][k], rows["dy"][k])
        got.extend(s["x"])
    n = len(got)
    assert n > 100
    np.testing.assert_array_equal(got, expected["x"][:n])


def test_odometry_object_fed_mice_wheels_and_fixes_in_time_order_equals_the_file_pipeline(logs):
    d = logs["faults-liftoff"]
    expected = moa.odometry(d / "robot.yaml", d, fuse_camera=True)
    log = moa.read_log(d / "robot.yaml", d)
    mice, wheels, camera = log["mice"], log["wheels"], log["camera"]
    odo = moa.Odometry(d / "robot.yaml", t0=mice["t"][0], fuse_camera=True)
    steps = []
    w = c = 0

    def feed_until(t):
        nonlocal w, c
        while c < len(camera["t"]) and camera["t"][c] <= t:
            theta, sx, sy = (None if np.isnan(v) else v
                             for v in (camera["theta"][c], camera["sx"][c], camera["sy"][c]))
            odo.push_fix(camera["t"][c], camera["x"][c], camera["y"][c], theta, sx, sy)
            c += 1
        while w < len(wheels["t"]) and wheels["t"][w] <= t:
            steps.append(odo.push_wheels(wheels["t"][w], wheels["vx"][w], wheels["vy"][w],
                                         wheels["omega"][w]))
            w += 1

    for k in range(len(mice["t"])):
        feed_until(mice["t"][k])
        squal = int(mice["squal"][k])
        steps.append(odo.push(mice["t"][k], int(mice["sensor"][k]), mice["dx"][k],
                              mice["dy"][k], squal if squal >= 0 else None,
                              int(mice["flags"][k])))
    feed_until(mice["t"][-1])
    steps.append(odo.finish(mice["t"][-1]))
    steps = [s for s in steps if len(s["t"])]
    for col in NUMERIC + ["pxx", "pxy", "pyy", "ptt"]:
        np.testing.assert_array_equal(np.concatenate([s[col] for s in steps]), expected[col],
                                      err_msg=col)
    np.testing.assert_array_equal(np.concatenate([s["excluded"] for s in steps]),
                                  expected["excluded"])


def test_odometry_object_reports_a_bad_row():
    cfg = pathlib.Path(__file__).resolve().parents[2] / "examples/logs/mixed-motion/robot.yaml"
    o = moa.Odometry(cfg, t0=0.0)
    o.push(0.01, 0, 1.0, 2.0)
    with pytest.raises(moa.Error, match="row at t = 0.005 s"):
        o.push(0.005, 0, 1.0, 2.0)


def test_huge_times_are_refused_as_by_the_command_line(tmp_path):
    # Issue #28: a time a double cannot resolve the epoch step at (1e300,
    # 1e20, 1e16) is refused at once, by the same reader as `moa odometry`.
    cfg = pathlib.Path(__file__).resolve().parents[2] / "examples/logs/mixed-motion/robot.yaml"
    for t in ["1e300", "1e20", "1e16"]:
        d = tmp_path / t
        d.mkdir()
        (d / "mice.csv").write_text(f"t,sensor,dx,dy\n{t},front,0,0\n")
        message = cli_error("odometry", "--config", cfg, "--log", d, "--out", tmp_path / "o.csv")
        assert "mice.csv:2: column 't': " + t + " s is outside -4e9..4e9 s" in message
        with pytest.raises(moa.Error) as e:
            moa.odometry(cfg, d)
        assert str(e.value) == message
    o = moa.Odometry(cfg, t0=0.0)
    with pytest.raises(moa.Error, match="time is outside -4e9..4e9 s"):
        o.push(1e300, 0, 1.0, 2.0)


def test_sparse_rows_are_refused_as_by_the_command_line(tmp_path):
    # Issue #28: rows an hour apart over a day would write 8.64 million still
    # epochs; the silences beyond --max-gap plus one epoch per row are refused
    # with the same message as `moa odometry`, at the first row at 7198 s.
    cfg = pathlib.Path(__file__).resolve().parents[2] / "examples/logs/mixed-motion/robot.yaml"
    d = tmp_path / "hour-apart"
    d.mkdir()
    rows = "".join(f"{k * 3599},{name},0,0\n" for k in range(25)
                   for name in ["front", "left", "rear", "right"])
    (d / "mice.csv").write_text("t,sensor,dx,dy\n" + rows)
    message = cli_error("odometry", "--config", cfg, "--log", d, "--out", tmp_path / "o.csv")
    assert "mice.csv:10: row at t = 7198 s: the sensors have been silent for 7197.90 s" in message
    with pytest.raises(moa.Error) as e:
        moa.odometry(cfg, d)
    assert str(e.value) == message
    o = moa.Odometry(cfg, t0=0.0)
    for t in [0.0, 3599.0]:
        for sensor in range(4):
            o.push(t, sensor, 0.0, 0.0)
    with pytest.raises(moa.Error, match="silences add up to more than --max-gap"):
        o.push(7198.0, 0, 0.0, 0.0)


def test_odometry_object_checks_its_arguments_as_the_command_line_does():
    # Issue #47, item 9: t0=nan looped for ever, finish(1e6) grew memory
    # until MemoryError, rate=1e6 was taken, flags were taken modulo 256,
    # fractional counts were accepted, a NaN wheel twist gave NaN poses.
    cfg = pathlib.Path(__file__).resolve().parents[2] / "examples/logs/mixed-motion/robot.yaml"
    for t0 in [float("nan"), float("inf"), 1e300]:
        with pytest.raises(moa.Error, match="t0 = .* s: not a time within -4e9..4e9 s"):
            moa.Odometry(cfg, t0=t0)
    with pytest.raises(moa.Error, match=r"rate: 1000000(\.0)?: must be within \[0.1, 10000\]"):
        moa.Odometry(cfg, t0=0.0, rate=1e6)
    o = moa.Odometry(cfg, t0=0.0)
    for flags in [256, -1]:
        with pytest.raises(moa.Error, match="flags .*: must be a whole number 0..255"):
            o.push(0.01, 0, 1.0, 0.0, flags=flags)
    with pytest.raises(moa.Error, match="dx 0.5: a count is a whole number"):
        o.push(0.01, 0, 0.5, 0.0)
    with pytest.raises(moa.Error, match="dx True: a count is a whole number, not a bool"):
        o.push(0.01, 0, True, 0)
    with pytest.raises(moa.Error, match="dy: counts are whole numbers, not bools"):
        o.push_rows([0.01], [0], [1], [False])
    with pytest.raises(moa.Error, match="flags 1.5: must be a whole number 0..255"):
        o.push_rows([0.01], [0], [1.0], [0.0], flags=[1.5])
    with pytest.raises(moa.Error, match="wheel twist beyond the plausible"):
        o.push_wheels(0.01, float("nan"), 0.0, 0.0)
    for sensor in range(4):
        o.push(0.01, sensor, 1.0, 0.0)
    for t_end in [float("inf"), 1e300, 1e6, 0.005]:
        with pytest.raises(moa.Error, match="finish: t_end = .* s: must be from the last row"):
            o.finish(t_end)
    o.finish(0.01)
    assert o.steps >= 1
    assert all(np.isfinite(o.pose))


def test_evaluate_on_arrays_refuses_times_going_back_and_absurd_poses():
    # Issue #47, item 9: decreasing times gave samples 0 and an error of 0.0.
    truth = {"t": [0.0, 1.0, 2.0], "x": [0.0, 1.0, 2.0], "y": [0.0] * 3, "theta": [0.0] * 3}
    back = {"t": [2.0, 1.0, 0.0], "x": [0.0, 1.0, 2.0], "y": [0.0] * 3, "theta": [0.0] * 3}
    with pytest.raises(moa.Error, match=r"odometry: t\[1\] = 1(\.0)? s: time goes backwards"):
        moa.evaluate(truth, back)
    absurd = dict(truth, theta=[0.0, 1.8e306, 0.0])
    with pytest.raises(moa.Error, match="odometry: pose 1 .* beyond the plausible"):
        moa.evaluate(truth, absurd)
    with pytest.raises(moa.Error, match=r"truth: t\[0\] = nan s is outside -4e9..4e9 s"):
        moa.evaluate(dict(truth, t=[float("nan"), 1.0, 2.0]), truth)


def test_calibrate_equals_the_written_config(logs, tmp_path):
    d = logs["calibration"]
    for method in ["exact", "kimlee"]:
        out = tmp_path / f"{method}.yaml"
        code, stdout, err = run("calibrate", "--method", method, "--config", d / "robot.yaml",
                                "--log", d, "--out", out)
        assert code == 0, err
        cal = moa.calibrate(d / "robot.yaml", d, method=method)
        written = moa.read_config(out)
        assert [s["name"] for s in cal.sensors] == written["names"]
        for i, s in enumerate(cal.sensors):
            np.testing.assert_allclose(s["position"], written["position"][i], rtol=0, atol=1e-9)
            np.testing.assert_allclose(s["scale"], written["scale"][i], rtol=0, atol=1e-9)
            assert abs(s["yaw"] - written["yaw"][i]) < 1e-9
            assert s["mirrored"] == written["mirrored"][i]
        assert cal.to_yaml() == out.read_text()
        assert cal.full_report() + f"calibrated config written to {out}\n" == stdout
        code, stdout, err = run("calibrate", "--method", method, "--config", d / "robot.yaml",
                                "--log", d, "--out", out, "--json")
        cli = json.loads(stdout)
        del cli["out"]
        assert json.loads(cal.to_json()) == cli


def test_calibrate_reports_observability_and_sigma(logs):
    d = logs["calibration"]
    cal = moa.calibrate(d / "robot.yaml", d, method="exact")
    for s in cal.sensors:
        assert all(s["estimated"].values())
        assert (s["sd_position"] > 0).all() and s["sd_yaw"] > 0
        assert s["information_eigenvalues"].shape == (5,)
    assert [o["name"] for o in cal.observability] == [s["name"] for s in cal.sensors]
    assert all((o["information_eigenvalues"] >= 1).all() for o in cal.observability)
    kimlee = moa.calibrate(d / "robot.yaml", d, method="kimlee")
    assert not kimlee.sensors[0]["estimated"]["yaw"]
    assert kimlee.sensors[0]["sd_yaw"] == 0


def test_calibrate_refuses_a_misfit_unless_forced(logs, tmp_path):
    # wheels.csv with omega zeroed: not the robot's twist (docs/calibration.md).
    d = tmp_path / "misfit"
    d.mkdir()
    for f in ["mice.csv", "robot.yaml"]:
        (d / f).write_bytes((logs["calibration"] / f).read_bytes())
    rows = (logs["calibration"] / "wheels.csv").read_text().splitlines()
    zeroed = [r if r.startswith(("#", "t")) else r.rsplit(",", 1)[0] + ",0" for r in rows]
    (d / "wheels.csv").write_text("\n".join(zeroed) + "\n")
    with pytest.raises(moa.Error, match="refused, the calibrated model does not explain"):
        moa.calibrate(d / "robot.yaml", d, method="exact")
    cal = moa.calibrate(d / "robot.yaml", d, method="exact", force=True)
    assert any("does not explain the data" in w for w in cal.warnings)
    assert not cal.usable
    assert cal.termination == "model-misfit"
    good = moa.calibrate(logs["calibration"] / "robot.yaml", logs["calibration"], method="exact")
    assert good.usable and good.termination == "converged"


def test_calibrate_against_a_ceiling_camera_equals_the_command(logs, tmp_path):
    # camera.csv from truth.csv: the centre's positions at every fourth row,
    # stamped 50 ms late; no wheels.csv.
    d = tmp_path / "ceiling"
    d.mkdir()
    for f in ["mice.csv", "robot.yaml"]:
        (d / f).write_bytes((logs["calibration"] / f).read_bytes())
    truth = read_csv(logs["calibration"] / "truth.csv")
    rows = [f"{float(t) + 0.05:.6f},{x},{y}"
            for k, (t, x, y) in enumerate(zip(truth["t"], truth["x"], truth["y"])) if k % 4 == 0]
    (d / "camera.csv").write_text("t,x,y\n" + "\n".join(rows) + "\n")
    out = tmp_path / "ceiling.yaml"
    code, stdout, err = run("calibrate", "--method", "exact", "--reference", "camera", "--config",
                            d / "robot.yaml", "--log", d, "--out", out, "--force")
    assert code == 0, err
    cal = moa.calibrate(d / "robot.yaml", d, method="exact", reference="camera", force=True)
    assert cal.to_yaml() == out.read_text()
    assert "positions only" in " ".join(cal.facts)
    assert abs(moa.read_config(out)["camera_latency"] - 0.05) < 0.005
    with pytest.raises(moa.Error, match="reference: unknown reference 'mocap'"):
        moa.calibrate(d / "robot.yaml", d, method="exact", reference="mocap")


def as_keywords(message):
    """The CLI's message with each flag as the option's keyword (--no-wheels: no_wheels):
    the library names options by their field, the CLI renders them as flags."""
    return re.sub(r"--([a-z][a-z-]*)", lambda m: m.group(1).replace("-", "_"), message)


def test_errors_carry_the_command_lines_message_with_keywords_for_flags(logs, tmp_path):
    d = logs["calibration"]
    cfg = d / "robot.yaml"
    out = tmp_path / "o.csv"
    empty = tmp_path / "empty"
    empty.mkdir()
    no_wheels = tmp_path / "no-wheels"
    no_wheels.mkdir()
    (no_wheels / "mice.csv").write_text("t,sensor,dx,dy\n0,m1,0,0\n")
    cases = [
        (("odometry", "--config", cfg, "--log", d, "--sensors", "m1,zz", "--out", out),
         lambda: moa.odometry(cfg, d, sensors=["m1", "zz"])),
        (("odometry", "--config", cfg, "--log", d, "--estimator", "wheels", "--no-wheels",
          "--out", out),
         lambda: moa.odometry(cfg, d, "wheels", no_wheels=True)),
        (("odometry", "--config", cfg, "--log", empty, "--out", out),
         lambda: moa.odometry(cfg, empty)),
        (("calibrate", "--method", "exact", "--config", cfg, "--log", no_wheels, "--out",
          tmp_path / "c.yaml"),
         lambda: moa.calibrate(cfg, no_wheels, method="exact")),
        (("calibrate", "--method", "guided", "--config", cfg, "--push-x", d, "--distance", "1",
          "--turns", "5", "--out", tmp_path / "c.yaml"),
         lambda: moa.calibrate(cfg, None, method="guided", push_x=d, distance=1, turns=5)),
    ]
    for args, call in cases:
        message = as_keywords(cli_error(*args))
        with pytest.raises(moa.Error) as e:
            call()
        assert str(e.value) == message
        assert "--" not in str(e.value)
    with pytest.raises(moa.Error, match="invalid option: rate"):
        moa.odometry(cfg, d, rate=float("nan"))
    with pytest.raises(TypeError, match="unknown option 'speed'"):
        moa.odometry(cfg, d, speed=3)


def test_simulate_in_memory_equals_the_written_log(logs, tmp_path):
    sim = moa.simulate("calibration", 4, out=tmp_path / "sim")
    files = moa.read_log(logs["calibration"] / "robot.yaml", logs["calibration"])
    for c in ["t", "sensor", "dx", "dy", "flags"]:
        np.testing.assert_array_equal(sim["mice"][c], files["mice"][c])
    # wheels.csv holds 9 significant digits.
    for c in ["t", "vx", "vy", "omega"]:
        np.testing.assert_allclose(sim["wheels"][c], files["wheels"][c], rtol=1e-8, atol=1e-12)
    for c in ["t", "x", "y", "theta"]:
        np.testing.assert_allclose(sim["truth"][c], files["truth"][c], rtol=0, atol=1e-9)
    assert sim["config"].to_yaml() == (logs["calibration"] / "robot.yaml").read_text()
    assert (tmp_path / "sim" / "mice.csv").read_text() == \
        (logs["calibration"] / "mice.csv").read_text()
    assert "calibration" in moa.scenarios()
    # No gyro in this scenario: no imu.csv, no imu rows.
    assert not (logs["calibration"] / "imu.csv").exists()
    assert "imu" not in files
    assert len(sim["imu"]["t"]) == len(sim["imu"]["gz"]) == 0


def read_rows(path, columns):
    """A log CSV's columns as floats, parsed here (csv module), not by moa."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    return {c: np.array([float(r[c]) for r in rows]) for c in columns}


def test_read_log_and_simulate_give_the_gyro_rows_of_imu_csv(tmp_path):
    d = tmp_path / "gyro"
    code, _, err = run("simulate", "--scenario", "gyro-compact", "--seed", 7, "--out", d,
                       "--quiet")
    assert code == 0, err
    f = read_rows(d / "imu.csv", ["t", "gz"])
    assert len(f["t"]) > 1000  # 100 rows/s over 33 s
    log = moa.read_log(d / "robot.yaml", d)
    assert set(log["imu"]) == {"t", "gz"}
    for c in ["t", "gz"]:
        assert log["imu"][c].dtype == np.float64
        np.testing.assert_array_equal(log["imu"][c], f[c], err_msg=c)
    assert (np.diff(log["imu"]["t"]) > 0).all()
    # The gyro's rows: at rest for the first 2 s it reads its bias (0.01 rad/s,
    # robot.yaml says 0), then the turns (up to 1.82 rad/s, scale 1.02).
    rest = log["imu"]["gz"][log["imu"]["t"] < 1.9]
    assert len(rest) > 150 and abs(rest.mean() - 0.01) < 2e-3
    assert 1.8 < log["imu"]["gz"].max() < 1.9 and log["imu"]["gz"].min() < -0.9
    # In memory, the same rows (imu.csv holds gz to 9 significant digits).
    sim = moa.simulate("gyro-compact", 7)
    np.testing.assert_array_equal(sim["imu"]["t"], f["t"])
    np.testing.assert_allclose(sim["imu"]["gz"], f["gz"], rtol=1e-8, atol=1e-12)


def test_read_config_gives_the_configs_arrays(logs):
    c = moa.read_config(logs["calibration"] / "robot.yaml")
    cfg = moa.Config(logs["calibration"] / "robot.yaml")
    assert c["names"] == cfg.names and len(cfg) == len(c["names"])
    assert c["position"].shape == (len(cfg), 2)
    again = moa.Config.from_yaml(cfg.to_yaml()).to_dict()
    for k in ["position", "yaw", "cpi", "scale", "mirrored"]:
        np.testing.assert_array_equal(again[k], c[k])


IMU_KEYS = {"scale", "bias", "noise_density", "bias_random_walk", "bias_sigma", "scale_sigma",
            "mount_yaw_sigma", "max_rate", "latency"}


def yaml_block(path, key):
    """A top-level block of a config, parsed here (PyYAML, else a flat parse of
    its `  name: number` lines), not by moa; None when the file has none."""
    text = pathlib.Path(path).read_text()
    try:
        import yaml
    except ImportError:
        block, inside = None, False
        for line in text.splitlines():
            line = line.split("#")[0].rstrip()
            if line == f"{key}:":
                block, inside = {}, True
            elif inside and line.startswith("  ") and ":" in line:
                name, value = line.strip().split(":", 1)
                block[name.strip()] = float(value)
            elif line and not line.startswith(" "):
                inside = False
        return block
    return yaml.safe_load(text).get(key)


def test_read_config_gives_the_imu_block(logs, tmp_path):
    d = tmp_path / "gyro"
    code, _, err = run("simulate", "--scenario", "gyro-compact", "--seed", 1, "--out", d,
                       "--quiet")
    assert code == 0, err
    for config in ["robot.yaml", "robot.true.yaml"]:
        expected = yaml_block(d / config, "imu")
        assert set(expected) == IMU_KEYS, config
        c = moa.read_config(d / config)
        assert c["imu"] == {k: float(v) for k, v in expected.items()}, config
        assert moa.Config(d / config).to_dict()["imu"] == c["imu"]
        again = moa.Config.from_yaml(moa.Config(d / config).to_yaml()).to_dict()
        assert again["imu"] == c["imu"]
    # The nominal config and the simulated gyro differ (scale 1 and 1.02).
    nominal, true = (moa.read_config(d / c)["imu"] for c in ["robot.yaml", "robot.true.yaml"])
    assert nominal["scale"] == 1.0 and true["scale"] == 1.02
    # A block that gives some keys: the others at their documented defaults.
    text = (logs["calibration"] / "robot.yaml").read_text()
    partial = moa.Config.from_yaml(text + "imu:\n  bias: 0.02\n  latency: -0.003\n").to_dict()
    assert partial["imu"] == {"scale": 1.0, "bias": 0.02, "noise_density": 1.5e-4,
                              "bias_random_walk": 1e-4, "bias_sigma": 0.05, "scale_sigma": 0.03,
                              "mount_yaw_sigma": 0.0035, "max_rate": 8.7, "latency": -0.003}
    # No imu: block: None, as camera_latency and wheels_latency without theirs.
    assert yaml_block(logs["calibration"] / "robot.yaml", "imu") is None
    for c in [moa.read_config(logs["calibration"] / "robot.yaml"),
              moa.Config(logs["calibration"] / "robot.yaml").to_dict()]:
        assert "imu" in c and c["imu"] is None


def test_evaluate_equals_the_command(logs, tmp_path):
    d = logs["faults-liftoff"]
    out = tmp_path / "odometry.csv"
    assert run("odometry", "--config", d / "robot.yaml", "--log", d, "--out", out)[0] == 0
    code, stdout, err = run("evaluate", "--truth", d / "truth.csv", "--odometry", out, "--json")
    assert code == 0, err
    cli = json.loads(stdout)
    assert moa.evaluate(d / "truth.csv", out) == cli
    truth = moa.read_log(d / "robot.yaml", d)["truth"]
    arrays = moa.evaluate(truth, moa.odometry(d / "robot.yaml", d))
    for k, v in cli.items():
        assert arrays[k] == pytest.approx(v, rel=1e-12, abs=1e-15), k


def test_stubs_declare_every_public_name():
    stub = pathlib.Path(__file__).resolve().parents[1] / "moa.pyi"
    tree = ast.parse(stub.read_text())
    declared = {n.name for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    public = {n for n in dir(moa) if not n.startswith("_")}
    assert public <= declared, public - declared
    assert "estimator" in moa.odometry.__doc__
    assert "bulk" in moa.Odometry.push_rows.__doc__
