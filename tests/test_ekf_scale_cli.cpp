// moa odometry --fuse-camera --ekf-scale end to end: the EKF's scale states
// on a simulated robot whose mice over-estimate the rotation by 3 %
// (tests/data/scenarios/square-radius-off.yaml: every sensor 3 mm further
// out than robot.yaml says; the true rotation scale is 0.1 / 0.103).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "moa/analysis/evaluate.hpp"
#include "moa/core/odometry.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/log.hpp"
#include "moa/formats/odometry_csv.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa {
namespace {

namespace fs = std::filesystem;

const fs::path kScenario = fs::path(MOA_TEST_DATA_DIR) / "scenarios" / "square-radius-off.yaml";
constexpr double kTrueScaleOmega = 0.1 / 0.103;
// One-sided Student t quantile at 99 % for 4 degrees of freedom (5 seeds), as
// tests/experiments/test_experiments.py.
constexpr double kT99For4 = 3.747;

std::vector<StampedPose> read_truth(const fs::path& file) {
  std::vector<StampedPose> truth;
  io::TruthReader reader(file);
  while (const auto row = reader.next()) truth.push_back({row->t, row->pose});
  return truth;
}

TrajectoryError errors_of(const fs::path& odometry, const std::vector<StampedPose>& truth) {
  TrajectoryErrorAccumulator acc(truth);
  io::TruthReader reader(odometry);
  while (const auto row = reader.next()) acc.add(row->t, row->pose);
  return acc.result();
}

TEST(EkfScaleCli, ScaleStatesReduceTheHeadingErrorOfAWrongRadius) {
  const auto dir = test::scratch_dir("ekf-scale");
  std::vector<double> plain_rms, scaled_rms;
  for (int seed = 101; seed <= 105; ++seed) {
    SCOPED_TRACE(::testing::Message() << "seed " << seed);
    const fs::path run = dir / std::to_string(seed);
    const auto sim = test::run_moa("simulate --quiet --scenario " + kScenario.string() +
                                   " --seed " + std::to_string(seed) + " --out " + run.string());
    ASSERT_EQ(sim.exit_code, 0) << sim.err;
    const std::string common = "odometry --config " + (run / "robot.yaml").string() + " --log " +
                               run.string() + " --fuse-camera --camera-latency 0.1 --out ";
    const auto plain = test::run_moa(common + (run / "plain.csv").string());
    ASSERT_EQ(plain.exit_code, 0) << plain.err;
    const auto scaled = test::run_moa(common + (run / "scaled.csv").string() + " --ekf-scale");
    ASSERT_EQ(scaled.exit_code, 0) << scaled.err;
    const auto truth = read_truth(run / "truth.csv");
    const TrajectoryError p = errors_of(run / "plain.csv", truth);
    const TrajectoryError s = errors_of(run / "scaled.csv", truth);
    plain_rms.push_back(p.rms_heading);
    scaled_rms.push_back(s.rms_heading);

    // The typed reader: the scale columns of the last row, none without --ekf-scale.
    const io::RobotConfig config = io::read_config(run / "robot.yaml");
    std::optional<io::OdometryRow> last;
    io::OdometryCsvReader reader(run / "scaled.csv", config, (run / "robot.yaml").string());
    while (auto row = reader.next()) last = std::move(row);
    ASSERT_TRUE(last && last->scale && last->scale_sd);
    io::OdometryCsvReader without(run / "plain.csv", config, (run / "robot.yaml").string());
    const auto first = without.next();
    ASSERT_TRUE(first);
    EXPECT_FALSE(first->scale || first->scale_sd);
    // The rotation scale is found within its sd; the translation scale is 1.
    const Eigen::Vector2d scale = *last->scale, sd = *last->scale_sd;
    std::printf(
        "seed %d: heading rms %.4f rad without the scale states, %.4f with; max %.4f, %.4f; "
        "translation rms %.2f mm, %.2f mm; s_v %.4f +- %.4f (true 1), s_w %.4f +- %.4f (true "
        "%.4f)\n",
        seed, p.rms_heading, s.rms_heading, p.max_heading, s.max_heading, p.rms_translation * 1e3,
        s.rms_translation * 1e3, scale(0), sd(0), scale(1), sd(1), kTrueScaleOmega);
    EXPECT_LT(std::abs(scale(0) - 1.0), 3.0 * sd(0));
    EXPECT_LT(std::abs(scale(1) - kTrueScaleOmega), 3.0 * sd(1));
    EXPECT_LT(sd(1), 0.01);  // tight enough to tell the 3 % apart
  }
  // Paired one-sided bound on the per-seed differences: the mean reduction
  // exceeds what the run-to-run spread could give by chance at 99 %.
  const auto n = static_cast<double>(plain_rms.size());
  std::vector<double> d;
  for (std::size_t i = 0; i < plain_rms.size(); ++i) d.push_back(scaled_rms[i] - plain_rms[i]);
  double mean = 0.0;
  for (const double x : d) mean += x / n;
  double var = 0.0;
  for (const double x : d) var += (x - mean) * (x - mean) / (n - 1.0);
  const double upper = mean + kT99For4 * std::sqrt(var / n);
  std::printf("heading rms: mean paired difference %.4f rad, 99 %% upper bound %.4f rad\n", mean,
              upper);
  EXPECT_LT(upper, 0.0);
  if (!HasFailure()) fs::remove_all(dir);
}

TEST(EkfScaleCli, ScaleStatesNeedCameraFusion) {
  const auto dir = test::scratch_dir("ekf-scale-refused");
  const SensorArray array = test::skewed_array();
  test::write_log(test::synthesise(array, test::mixed_motion, 0.5, 0.01), array,
                  {"a", "b", "c", "d"}, dir);
  const auto r = test::run_moa("odometry --config " + (dir / "robot.yaml").string() + " --log " +
                               dir.string() + " --ekf-scale --out " + (dir / "o.csv").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--fuse-camera"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "o.csv"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace moa
