// The experiments' entry points, listed once in registry.cpp.
#pragma once

#include "moa/experiments/experiment.hpp"

namespace moa::experiments {

Result sekimori_table4(const Options& options);
Result sekimori_fig6(const Options& options);
Result robust_faults(const Options& options);
Result kimlee_example(const Options& options);
Result calibration_crb(const Options& options);
Result self_calibration(const Options& options);
Result gyro(const Options& options);
Result random_worlds(const Options& options);

}  // namespace moa::experiments
