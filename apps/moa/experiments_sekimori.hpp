// Sekimori & Miyazaki's experiments rerun on the simulator.
#pragma once

#include <cstdint>

namespace moa::cli {

/// Table 4: average over runs of the maximum translation (mm) and heading
/// (deg) error, speeds (a) and (b), wheels / 2 mice / 4 mice voting /
/// 4 mice consensus / 4 mice oracle, the paper's figures beside ours.
/// Runs use seeds seed, seed+1, ..., seed+runs-1.
int run_sekimori_table4(int runs, std::uint64_t seed, bool json);

/// Fig. 6 / Section 4.3 at speed (b): camera alone, wheel dead reckoning,
/// wheels + camera, mouse dead reckoning, mice + camera (EKF).
int run_sekimori_fig6(int runs, std::uint64_t seed, bool json);

}  // namespace moa::cli
