// Random worlds: a whole robot, its sensors, path, wheels, gyro, reference
// and faults drawn from one seed, as scenario YAML (docs/simulator.md,
// "Random worlds"). The text is the world: `moa simulate --random SEED`
// writes it beside the log as scenario.yaml, and `moa simulate --scenario
// scenario.yaml` replays it (or an edited copy) to the same bytes.
//
// A family narrows the draw: `clean` (no fault, speeds under the sensors'
// rating, the gyro under its full scale), `faults` (faults of every class on
// the sensors, the gyro and the wheels, alone or several at once), `gyro`
// (always a gyro, miscalibrated, stuck, stepping or saturating), `floor`
// (floor changes, per sensor or all together, and intermittent lifts),
// `calibration` (large build errors, wheels beside the sensors), `any`
// (each seed one of the others). The ranges are in docs/simulator.md.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "moa/sim/scenario.hpp"

namespace moa::sim {

struct RandomWorld {
  std::string family;  ///< the family drawn from (`any` resolved to the one drawn)
  std::string yaml;    ///< the scenario, as parse_scenario reads it
  Scenario scenario;   ///< parsed from yaml
  /// One line: drive, sensors, rates, wheels, gyro, reference, faults.
  std::string summary;
};

/// The families, in documentation order.
const std::vector<std::string>& random_families();

/// The world of `seed` in `family`; the same seed and family give the same
/// text on any machine. Throws std::invalid_argument for an unknown family.
RandomWorld random_scenario(std::uint64_t seed, std::string_view family);

}  // namespace moa::sim
