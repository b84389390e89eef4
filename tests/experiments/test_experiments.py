"""The papers' experiments, tested as a user would check them.

1. Reproduction: every run of every row of sekimori-table4, sekimori-fig6,
   robust-faults and self-calibration comes with the moa calls that
   recompute it; running them must give the same figures, exactly (shortest
   round-trip numbers), and for self-calibration the same estimates.
2. Properties, never a paper's constant nor an ordering the simulator was
   fitted to give. Margins come from the run-to-run spread: a paired
   one-sided t bound on the per-seed differences at 99 %,
   mean(d) <= t(0.99, n - 1) sd(d) / sqrt(n) + floor, with the floor the
   per-epoch quantisation scale (0.5 mm) so identical methods pass.

Seeds: the estimators' thresholds were chosen on seeds 1-5 (see
core/noise_model.hpp); these tests use seeds from 101, the docs from 201.

Run by ctest: python3 test_experiments.py MOA_BINARY
"""
import json
import math
import os
import shlex
import subprocess
import sys
import tempfile
import unittest

MOA = None
SEED = 101
RUNS = 5
# One-sided Student t quantile at 99 % for n - 1 = 4 degrees of freedom.
T99_4 = 3.747
FLOOR_M = 5e-4


def moa(*args):
    out = subprocess.run([MOA, *args], capture_output=True, text=True)
    if out.returncode != 0:
        raise AssertionError(f"moa {' '.join(args)}: exit {out.returncode}: {out.stderr}")
    return out.stdout


_cache = {}


def experiment(name):
    if name not in _cache:
        _cache[name] = json.loads(
            moa("experiment", name, "--runs", str(RUNS), "--seed", str(SEED), "--json"))
    return _cache[name]


def row(result, **labels):
    found = [r for r in result["rows"] if all(r.get(k) == v for k, v in labels.items())]
    assert len(found) == 1, (labels, [r.get("method") for r in result["rows"]])
    return found[0]


def per_seed(r, figure="max_translation_m"):
    return {run["seed"]: run[figure] for run in r["runs"]}


def not_worse(test, a, b, what, figure="max_translation_m"):
    """a's figure is not worse than b's beyond the paired t bound."""
    xa, xb = per_seed(a, figure), per_seed(b, figure)
    assert xa.keys() == xb.keys()
    d = [xa[s] - xb[s] for s in xa]
    n = len(d)
    mean = sum(d) / n
    sd = math.sqrt(sum((x - mean) ** 2 for x in d) / (n - 1))
    bound = T99_4 * sd / math.sqrt(n) + FLOOR_M
    test.assertLessEqual(mean, bound, f"{what}: mean paired difference {mean:.5f} m > {bound:.5f} m")


class Reproduction(unittest.TestCase):
    def check_estimates(self, result, scenario, seed, csv_path):
        [scale] = [s for s in result["scale"] if s["scenario"] == scenario]
        [series] = [x for x in scale["runs"] if x["seed"] == seed]
        with open(csv_path) as f:
            lines = f.read().splitlines()
        self.assertEqual(lines[0], "t,sensor,scale_x,scale_y,yaw_offset,"
                         "filter_scale_x,filter_scale_y,filter_yaw_offset,"
                         "filter_sd_scale_x,filter_sd_scale_y,filter_sd_yaw_offset")
        rows = [line.split(",") for line in lines[1:] if line.split(",")[1] == scale["sensor"]]
        # The experiment reports the filter's estimates (the last three columns).
        self.assertEqual([float(x[0]) for x in rows], series["t_s"], scenario)
        self.assertEqual([float(x[5]) for x in rows], series["scale_x"], scenario)
        self.assertEqual([float(x[6]) for x in rows], series["scale_y"], scenario)
        self.assertEqual([float(x[7]) for x in rows], series["yaw_offset_rad"], scenario)

    def test_every_run_is_reproduced_by_its_moa_calls(self):
        checked = 0
        checked_estimates = 0
        for name in ("sekimori-table4", "sekimori-fig6", "robust-faults", "self-calibration"):
            result = json.loads(moa("experiment", name, "--runs", "1", "--seed", "7", "--json"))
            for r in result["rows"]:
                for run in r["runs"]:
                    calls = run.get("reproduce")
                    if not calls:
                        continue  # camera alone: a comparison of camera.csv, no moa call
                    with tempfile.TemporaryDirectory() as scratch:
                        out = os.path.join(scratch, "out")
                        last = None
                        for call in calls:
                            words = shlex.split(call.replace("$OUT", out))
                            self.assertEqual(words[0], "moa")
                            last = moa(*words[1:])
                        got = json.loads(last)
                        estimates = os.path.join(out, "self-calibration.csv")
                        if name == "self-calibration" and os.path.exists(estimates):
                            self.check_estimates(result, r["scenario"], run["seed"], estimates)
                            checked_estimates += 1
                    for figure in ("max_translation_m", "rms_translation_m", "max_heading_rad",
                                   "rms_heading_rad", "samples"):
                        self.assertEqual(got[figure], run[figure],
                                         f"{name} {r.get('method')}: {figure}")
                    checked += 1
        self.assertGreaterEqual(checked, 10)
        self.assertEqual(checked_estimates, 2)  # self-calibration: one per scenario


class Table4(unittest.TestCase):
    def test_consensus_is_not_worse_than_the_oracle_or_the_voting(self):
        result = experiment("sekimori-table4")
        for speed in ("a", "b"):
            consensus = row(result, speed=speed, method="4 mice, consensus")
            not_worse(self, consensus, row(result, speed=speed, method="4 mice, oracle selection"),
                      f"({speed}) consensus vs oracle")
            not_worse(self, consensus, row(result, speed=speed, method="4 mice, voting (Sekimori)"),
                      f"({speed}) consensus vs voting")

    def test_four_mice_with_selection_beat_two(self):
        # Redundancy, not the simulator's fit: the same sensors' counts, two of
        # them against four with a selection.
        result = experiment("sekimori-table4")
        for speed in ("a", "b"):
            not_worse(self, row(result, speed=speed, method="4 mice, consensus"),
                      row(result, speed=speed, method="2 mice (m1, m3)"), f"({speed})")

    def test_fitted_rows_are_labelled(self):
        result = experiment("sekimori-table4")
        for r in result["rows"]:
            self.assertEqual(r["simulator_fitted_to_paper"], r["method"] == "wheels")
        text = moa("experiment", "sekimori-table4", "--runs", "1", "--seed", str(SEED))
        self.assertIn("fitted", text)


class Fig6(unittest.TestCase):
    def test_camera_error_matches_its_configured_noise(self):
        # sekimori-b: 5 mm per axis, so the 2-D RMS is sqrt(2) 5 mm; ~130 fixes
        # per run and 5 runs give a relative standard error of the RMS of
        # 1 / sqrt(4 * 650) = 2 %: 10 % is five of them.
        camera = row(experiment("sekimori-fig6"), method="camera alone")
        expected = math.sqrt(2) * 0.005
        self.assertAlmostEqual(camera["rms_translation_m"], expected, delta=0.1 * expected)

    def test_fusion_is_not_worse_than_either_source(self):
        result = experiment("sekimori-fig6")
        mice_camera = row(result, method="mice + camera (EKF)")
        not_worse(self, mice_camera, row(result, method="mouse dead reckoning (consensus)"),
                  "mice + camera vs mice", "rms_translation_m")
        not_worse(self, mice_camera, row(result, method="camera alone"), "mice + camera vs camera",
                  "rms_translation_m")
        not_worse(self, row(result, method="wheels + camera (EKF)"),
                  row(result, method="wheel dead reckoning"), "wheels + camera vs wheels",
                  "rms_translation_m")


class RobustFaults(unittest.TestCase):
    def test_consensus_against_voting_and_oracle(self):
        result = experiment("robust-faults")
        for fault in ("tracking loss", "liftoff, no flag", "dirty floor", "spikes", "stuck",
                      "zero reading", "drift", "drift, step", "runaway", "common-mode dropout"):
            consensus = row(result, fault=fault, method="consensus")
            not_worse(self, consensus, row(result, fault=fault, method="voting (Sekimori)"),
                      f"{fault}: consensus vs voting")
            # Known limits (docs/experiments.md): a frozen register in a steady cruise is
            # consistent until the motion changes; the dropouts are bridged (its own test).
            if fault not in ("stuck", "common-mode dropout"):
                not_worse(self, consensus, row(result, fault=fault, method="oracle selection"),
                          f"{fault}: consensus vs oracle")

    def test_every_fault_within_twice_the_oracle(self):
        # Issue #27's bound for every case, per seed: the selection that
        # knows the faults at most halves the error of the consensus; for the
        # register frozen while another sensor drifts, of the consensus with
        # self-calibration, the check (alone it is 1.5-3 times: the
        # drift pulls until the test alarms, docs/experiments.md).
        result = experiment("robust-faults")
        for fault in ("tracking loss", "liftoff, no flag", "dirty floor", "spikes", "stuck",
                      "zero reading", "drift", "drift, step", "frozen, other drifts",
                      "runaway", "common-mode dropout"):
            method = ("consensus + self-calibration" if fault == "frozen, other drifts" else
                      "consensus")
            consensus = per_seed(row(result, fault=fault, method=method), "max_translation_m")
            oracle = per_seed(row(result, fault=fault, method="oracle selection"),
                              "max_translation_m")
            for seed, error in consensus.items():
                self.assertLessEqual(error, 2 * oracle[seed] + FLOOR_M, f"{fault}: seed {seed}")

    def test_common_mode_dropout_is_bridged(self):
        # Issue #27's bound: every case within twice the selection that knows
        # the faults (which bridges the dropouts with the slipping wheels).
        # Before the common-mode test the consensus took the standstill:
        # 4.6 m and 102 deg on seed 1.
        result = experiment("robust-faults")
        consensus = per_seed(row(result, fault="common-mode dropout", method="consensus"),
                             "max_translation_m")
        oracle = per_seed(row(result, fault="common-mode dropout", method="oracle selection"),
                          "max_translation_m")
        for seed, error in consensus.items():
            self.assertLessEqual(error, 2 * oracle[seed], f"seed {seed}")

    def test_self_calibration_on_a_drifting_sensor(self):
        # The drift as a linear ramp: the consensus with self-calibration is
        # not worse than without. As a step (a change of floor) it is not
        # worse than the voting; against the consensus alone it is a known
        # limit on this short path (docs/experiments.md: the health monitor
        # excludes the stepped sensor before the filter has followed it).
        result = experiment("robust-faults")
        not_worse(self, row(result, fault="drift", method="consensus + self-calibration"),
                  row(result, fault="drift", method="consensus"),
                  "drift: consensus + self-calibration vs consensus")
        not_worse(self, row(result, fault="drift, step", method="consensus + self-calibration"),
                  row(result, fault="drift, step", method="voting (Sekimori)"),
                  "drift, step: consensus + self-calibration vs voting")


if __name__ == "__main__":
    MOA = sys.argv.pop(1)
    unittest.main(verbosity=2)
