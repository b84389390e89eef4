#include "moa/runs/evaluate.hpp"

#include <fmt/core.h>

#include <vector>

#include "moa/formats/error.hpp"
#include "moa/formats/log.hpp"

namespace moa::io {

TrajectoryError evaluate_files(const std::filesystem::path& truth_file,
                               const std::filesystem::path& odometry_file) {
  std::vector<StampedPose> truth;
  for (const auto& row : read_all<TruthRow>(truth_file)) truth.push_back({row.t, row.pose});
  if (truth.size() < 2) {
    throw Error(fmt::format("{}: needs at least two rows", truth_file.string()));
  }
  // odometry.csv begins with t,x,y,theta: the truth reader reads exactly those.
  TruthReader odometry(odometry_file);
  TrajectoryErrorAccumulator acc(truth);
  while (const auto row = odometry.next()) acc.add(row->t, row->pose);
  const TrajectoryError e = acc.result();
  if (e.samples == 0) {
    throw Error(fmt::format("{}: no row lies within the time span of {}", odometry_file.string(),
                            truth_file.string()));
  }
  return e;
}

}  // namespace moa::io
