// The literal formulations that moa's estimators are measured against
// (moa bench and bench/): everything recomputed per update on dynamic
// matrices, the way the papers write it. Not for use outside benchmarks.
#pragma once

#include <Eigen/Core>

#include "moa/core/array.hpp"
#include "moa/core/se2.hpp"

namespace moa::baseline {

/// Kim & Lee eq. (7)-(8) / Sekimori eq. (5): x = A^+ u with the
/// pseudo-inverse of the stacked 2N x 3 Jacobian computed for this update.
Twist2 naive_ls(const SensorArray& array, const ArraySample& sample);

/// Sekimori & Miyazaki Section 3.2 as written: for every pair, A^+ of its
/// 4 x 3 system (eq. (5)) and the residual E_ij (eq. (4)); votes (eq. (7));
/// B^+ over the reliable sensors (eq. (9)). Returns the twist, or the zero
/// twist when fewer than two sensors are reliable.
Twist2 naive_sekimori(const SensorArray& array, const ArraySample& sample, double e_th, int r_th);

}  // namespace moa::baseline
