// Writes a simulated run as a log directory (docs/formats/log.md, version 1)
// with its configs:
//   mice.csv         t,sensor,dx,dy,squal,flags         (in stamp order)
//   wheels.csv       t,vx,vy,omega                      (when the scenario has a drive)
//   camera.csv       t,x,y[,theta],sx,sy,t_arrival,outlier   (when it has a camera; t = the
//                    stamp at arrival, capture + latency + jitter; theta in mode mocap)
//   truth.csv        t,x,y,theta,vx,vy,omega            (twist over the frame ending at t)
//   faults.csv       t,sensor,faults,faulty_frames,clean_dx,clean_dy   (moa extension:
//                    one row per mice.csv row, FaultBit bits and the counts the
//                    sensor would have reported without its faults)
//   robot.yaml       the nominal robot (what the user believes)
//   robot.true.yaml  the simulated robot
//   faults.json      the faults' truth per source and interval (fault_truth.hpp)
//   scenario.yaml    when given: the scenario's text (a random world, to replay and edit)
// The run is written into a hidden directory beside the target and moved
// into place at the end: the target must be absent, empty, or a previous
// run (only these files, mice.csv from moa simulate), which is replaced
// whole; never a mix of two runs. The same scenario and seed give the same
// bytes.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string_view>

#include "moa/sim/scenario.hpp"
#include "moa/sim/simulate.hpp"

namespace moa::sim {

struct LogSummary {
  std::int64_t frames = 0;  ///< sensor frames simulated
  double duration = 0.0;    ///< s
  std::int64_t mice_rows = 0;
  std::int64_t wheel_rows = 0;
  std::int64_t camera_rows = 0;
  std::int64_t truth_rows = 0;
  std::int64_t faulty_rows = 0;  ///< mice.csv rows with a fault acting
};

/// Simulates and writes the log into `dir` (created if needed). Throws
/// io::Error naming the file or directory on failure (a directory holding
/// anything else is refused before the run), leaving no partial file.
LogSummary write_log(const Scenario& scenario, std::uint64_t seed, const std::filesystem::path& dir,
                     const Progress& progress = {}, std::string_view scenario_text = {});

}  // namespace moa::sim
