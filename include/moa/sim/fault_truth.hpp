// faults.json: the truth of a run's faults, per source and interval, beside
// faults.csv's per-row bits (docs/simulator.md, "faults.json").
//
// Declared faults come from the scenario (what it asked for: a sensor's
// window faults, the gyro's stuck windows and bias steps, the wheels' slip
// bursts); emergent ones from the simulated rows (a sensor's tracking loss,
// which the path's speed causes, and the gyro's saturation: a turn past its
// full scale in some frame of the row). Rows of one source that are faulty, with gaps of at most
// one row, make one interval [first row's start, last row's end], on the true clock (not the
// stamps).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "moa/sim/scenario.hpp"
#include "moa/sim/simulate.hpp"

namespace moa::sim {

struct FaultInterval {
  std::string source;     ///< a sensor's name, "gyro" or "wheels"
  std::string kind;       ///< liftoff | dirty | spikes | stuck | drift | tracking_loss |
                          ///< bias_step | saturated | slip_burst
  double start = 0.0;     ///< s
  double end = 0.0;       ///< s (a drift or a bias step: the run's end)
  bool emergent = false;  ///< found in the rows, not declared by the scenario
  /// The fault's size: dirty `retained`, drift `scale`, spikes `magnitude`
  /// (counts), bias_step `step` (rad/s), slip_burst `slip`; 0 otherwise.
  double amount = 0.0;
};

/// Collects the emergent faults from the rows as they are made.
class FaultTruth {
 public:
  explicit FaultTruth(const Scenario& scenario);
  void mice(const MiceRecord& record);
  void imu(const ImuRecord& record, double row_start);
  /// Declared faults first (scenario order), then emergent ones in the
  /// order they closed, those still open at the run's end last.
  std::vector<FaultInterval> intervals() const;
  /// {"scenario", "seed", "duration", "faults": [{"source", "kind", "start",
  ///  "end", "emergent", "amount"}], "unobservable": [text]}
  std::string json(std::uint64_t seed) const;

 private:
  struct Open {
    bool open = false;
    double start = 0.0, end = 0.0;
  };
  void extend(std::vector<FaultInterval>& out, Open& open, const std::string& source,
              const char* kind, bool faulty, double start, double end, double period);
  const Scenario& scenario_;
  double row_period_;
  double imu_period_;
  std::vector<Open> loss_;  ///< per sensor
  Open saturated_;
  std::vector<FaultInterval> emergent_;
};

}  // namespace moa::sim
