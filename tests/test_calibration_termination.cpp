// The calibration summary's termination and `usable` verdict
// (runs/calibration_run.hpp) against the solver's own results, read
// independently: convergence and the model check (exact), the rank of S
// counted from its singular values and threshold (kimlee).
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <variant>

#include "moa/formats/config.hpp"
#include "moa/runs/calibration_run.hpp"
#include "support/run.hpp"
#include "support/synth.hpp"

namespace moa::io {
namespace {

namespace fs = std::filesystem;

fs::path simulated_calibration_log() {
  const fs::path dir = test::scratch_dir("calibration_termination");
  const auto r = test::run_moa("simulate --scenario calibration --seed 1 --out " + dir.string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return dir;
}

TEST(CalibrationSummary, ExactIsUsableWhenItConvergedAndItsModelFits) {
  const fs::path dir = simulated_calibration_log();
  const std::string config_path = (dir / "robot.yaml").string();
  const CalibrationSummary s =
      calibrate_log(read_config(config_path), config_path, dir, CalibrationMethod::kExact, {});
  const auto& cal = std::get<ExactCalibration>(s.result);
  const bool fits = cal.converged && !cal.model_misfit && !cal.check.misfit();
  EXPECT_EQ(s.usable, fits);
  EXPECT_EQ(s.termination == CalibrationTermination::kConverged, fits);
  EXPECT_TRUE(s.usable) << "a clean simulated calibration drive";
  EXPECT_NE(s.to_json().find(R"("usable": true, "termination": "converged")"), std::string::npos)
      << s.to_json();
  fs::remove_all(dir);
}

TEST(CalibrationSummary, KimLeeIsUnderdeterminedWhenSIsRankDeficient) {
  const fs::path dir = simulated_calibration_log();
  const std::string config_path = (dir / "robot.yaml").string();
  const RobotConfig config = read_config(config_path);
  const CalibrationSummary s =
      calibrate_log(config, config_path, dir, CalibrationMethod::kKimLee, {});
  const auto& cal = std::get<KimLeeCalibration>(s.result);
  int rank = 0;  // singular values above the threshold, counted here
  for (const double sv : cal.singular_values) rank += sv > cal.threshold ? 1 : 0;
  const int unknowns = 2 * config.array.size();
  const bool few = cal.measurements < unknowns - 2;
  const CalibrationTermination expected = rank < unknowns ? CalibrationTermination::kUnderdetermined
                                          : few ? CalibrationTermination::kTooFewMeasurements
                                                : CalibrationTermination::kConverged;
  EXPECT_EQ(s.termination, expected) << to_name(s.termination) << " rank " << rank;
  EXPECT_EQ(s.usable, expected == CalibrationTermination::kConverged);
  fs::remove_all(dir);
}

TEST(CalibrationSummary, TerminationNamesRoundTrip) {
  for (const auto& entry : EnumNames<CalibrationTermination>::kTable) {
    EXPECT_EQ(from_name<CalibrationTermination>(to_name(entry.value)), entry.value);
  }
  EXPECT_FALSE(from_name<CalibrationTermination>("solved"));
}

}  // namespace
}  // namespace moa::io
