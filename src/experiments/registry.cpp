#include <algorithm>

#include "experiments_list.hpp"

namespace moa::experiments {
namespace {

// Sorted by name.
constexpr Experiment kAll[] = {
    {"calibration-crb",
     "Exact calibration against the Cramer-Rao bound: bias, spread and efficiency of each "
     "parameter, against wheels (default 50 trials), motion capture and a ceiling camera "
     "(default 16 seeds each)",
     calibration_crb},
    {"gyro",
     "Heading error of the mouse array alone, the gyro alone and fused, on a compact array, the "
     "papers' layout and one sensor (default 5 runs)",
     gyro},
    {"kimlee-example",
     "Kim & Lee Section IV: calibration of the three-mouse example, eqs. (51)-(53), and the "
     "velocity estimates of Fig. 3 (default 200 runs)",
     kimlee_example},
    {"random",
     "Random worlds (moa simulate --random): every estimator's max errors against selection, "
     "which knows the faults, and the oracle, which knows the calibration too; failures, worst "
     "seeds, consistency (--family F --seeds A-B; default any, 20 seeds from --seed)",
     random_worlds},
    {"robust-faults",
     "Each simulated sensor fault alone: least squares, voting, consensus, oracle (default 5 runs)",
     robust_faults},
    {"sekimori-fig6",
     "Sekimori & Miyazaki Fig. 6: camera, wheels, mice, and each fused by the EKF, speed (b) "
     "(default 5 runs)",
     sekimori_fig6},
    {"sekimori-table4",
     "Sekimori & Miyazaki Table 4: max errors of wheels, 2 mice, voting, consensus, oracle "
     "(default 10 runs)",
     sekimori_table4},
    {"self-calibration",
     "Online self-calibration of a drifting and a stepping sensor scale: estimated vs true scale "
     "over time, error with and without, oracle (default 5 runs)",
     self_calibration},
};

}  // namespace

std::span<const Experiment> all() { return kAll; }

const Experiment* find(std::string_view name) {
  const auto it = std::find_if(std::begin(kAll), std::end(kAll),
                               [&](const Experiment& e) { return name == e.name; });
  return it == std::end(kAll) ? nullptr : &*it;
}

}  // namespace moa::experiments
