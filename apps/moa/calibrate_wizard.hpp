// moa calibrate --guided --live: the guided calibration as a conversation in
// the terminal (calibrate_wizard.cpp). cmd_calibrate.cpp registers the flags
// and hands over the run when --live is given.
#pragma once

#include <CLI/CLI.hpp>
#include <optional>
#include <string>

#include "live_source.hpp"
#include "moa/calibration/guided.hpp"

namespace moa::cli {

struct WizardArgs {
  bool guided = false;  ///< --guided (without --live: the same as --method guided)
  bool live = false;    ///< --live: the wizard
  SourceFlags source;
  bool no_push_y = false;
  // From cmd_calibrate's own flags:
  bool imu = true;                      ///< not --no-imu: the spin's gyro rows calibrate the gyro
  std::string imu_reference = "array";  ///< --imu-reference: array only, live
  std::string config, out;
  std::optional<double> distance, turns;
  GuidedTolerances tolerances;
};

/// --guided, --live, the source flags (--mouse, --serial, --replay, ...) and
/// --no-push-y.
void add_wizard_flags(CLI::App* cmd, WizardArgs& args);
/// Throws io::Error when a flag of the live calibration is given without --live.
void refuse_live_flags(const WizardArgs& args);
/// Runs the wizard; the exit code.
int run_wizard(const WizardArgs& args);

}  // namespace moa::cli
