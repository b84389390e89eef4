// Writes the noise-free example log shipped in examples/logs/mixed-motion:
//   synth_log DIR [DURATION_S [ROW_PERIOD_S]]
#include <algorithm>
#include <cstdlib>
#include <iostream>

#include "support/synth.hpp"

int main(int argc, char** argv) {
  // Any argument that looks like an option (--help, -h) prints the usage
  // instead of becoming a directory of that name.
  if (argc < 2 || argv[1][0] == '-') {
    std::cerr << "usage: synth_log DIR [DURATION_S [ROW_PERIOD_S]]\n";
    return argc < 2 ? 2 : 0;
  }
  const double duration = argc > 2 ? std::atof(argv[2]) : 20.0;
  const auto array = moa::test::skewed_array();
  const double row_period = argc > 3 ? std::atof(argv[3]) : 0.01;
  const auto log = moa::test::synthesise(array, moa::test::mixed_motion, duration, row_period, true,
                                         std::min(1e-4, row_period));
  moa::test::write_log(log, array, {"front", "left", "rear", "right"}, argv[1]);
  std::cout << "wrote " << argv[1] << "\n";
  return 0;
}
