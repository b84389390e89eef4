// calibration-crb's rows for a pose reference: the exact calibration
// against motion capture (calib-mocap) and a ceiling camera (calib-camera),
// over simulated seeds, against the Cramer-Rao bound.
#pragma once

#include <string>
#include <string_view>

#include "moa/experiments/experiment.hpp"
#include "moa/formats/json.hpp"

namespace moa::experiments {

/// Runs `scenario` (calib-mocap or calib-camera) for `runs` seeds from
/// options.seed, calibrates each as `moa calibrate --method exact
/// --reference camera` does, appends the table to `text` and one object to
/// `json` (calibration_crb_pose.cpp has the definitions).
void pose_reference_crb(std::string_view scenario, const Options& options, int runs,
                        std::string& text, io::JsonWriter& json);

}  // namespace moa::experiments
