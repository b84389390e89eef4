// Which mounting parameters a motion excites, and which to keep at nominal.
//
// The data's Fisher information about one sensor's parameters
// (px, py, yaw, sx, sy) is a 5x5 matrix F_i (see calibrate_exact.hpp). Its
// eigenvectors with small eigenvalues are the combinations the motion does
// not excite: a pure rotation gives counts_i / dt = omega q_i, q_i = M_i J p_i,
// two numbers for five parameters (rank 2: yaw and scale are not separable
// from position); no rotation leaves the position unseen (rank 3); motion
// along one robot axis only leaves one column of M_i unseen (rank 4).
//
// Scaled by a generous mounting error D = diag(prior_sd) (1 cm, 1 cm,
// 0.1 rad, 5 %, 5 %), an eigenvalue lambda of D F_i D says how much the
// data shrinks that error along its eigenvector: the 1-sigma after
// calibration is 1/sqrt(lambda) prior standard deviations. A direction is
// called excited when
//   lambda >= min_information (1: the estimate is at least as good as the
//   nominal value would be)  and  lambda >= relative_floor * lambda_max
//   (numerical rank).
// Directions a motion does not excite at all have lambda ~ 0 whatever the
// noise; the absolute test also keeps at nominal what too few or too noisy
// samples cannot tell better than the nominal config does.
// The parameters to estimate are then chosen as the largest subset whose
// block of D F_i D passes that test in all its directions; among subsets
// of equal size the one that keeps parameters latest in the priority order
//   scale y, scale x, yaw, position x, position y
// at nominal wins (scales are closest to nominal on real robots, positions
// are what every estimate needs). Kept parameters stay at nominal.
#pragma once

#include <array>

#include "moa/calibration/calibrate.hpp"

namespace moa {

struct ObservabilityOptions {
  /// Generous mounting error, (m, m, rad, 1, 1).
  MountVector prior_sd = (MountVector() << 0.01, 0.01, 0.1, 0.05, 0.05).finished();
  double min_information = 1.0;
  double relative_floor = 1e-9;
};

struct SensorObservability {
  std::array<bool, kMountParameters> estimated{};        ///< false: kept at nominal
  MountVector scaled_eigenvalues = MountVector::Zero();  ///< of D F_i D, ascending
  bool all() const {
    for (bool e : estimated)
      if (!e) return false;
    return true;
  }
  int count() const {
    int c = 0;
    for (bool e : estimated) c += e ? 1 : 0;
    return c;
  }
};

/// The subset of parameters to estimate from the information matrix F_i.
SensorObservability choose_estimated(const MountMatrix& information,
                                     const ObservabilityOptions& options = {});

}  // namespace moa
