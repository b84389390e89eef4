// Sekimori & Miyazaki Section 3.2: pairwise residuals vote out unreliable
// sensors; least squares over the reliable ones; wheels when too few remain.
//
// For a pair (i, j) the four equations of eq. (3) in the robot-frame point
// displacements a = (u_i dt, u_j dt) have three unknowns u = (dx, dy, dtheta);
// the least-squares residual of eq. (4) is E_ij = |(I - A A^+) a|^2. A has
// rank 3, so I - A A^+ = n n^T with n the unit normal of A's column space,
// and E_ij = (n . a)^2: n is computed once per pair.
// Reliability, eq. (7): r_i = #{j != i : E_ij <= E_th}; sensors with
// r_i >= r_th are used in the least squares of eqs. (8)-(9) (unweighted, as
// written); with fewer than two reliable sensors the wheel twist is used
// (or, without wheels, the last twist is held).
//
// Default thresholds (DESIGN: documented and justified):
//   E_th = (0.2 mm)^2 = 4e-8 m^2 per sample: at 800 cpi quantisation gives
//   E ~ 3e-10 m^2 and a 2 % resolution mismatch at 0.5 m/s over 10 ms about
//   1e-8 m^2, while a sensor losing track at 0.3 m/s gives ~9e-6 m^2.
//   r_th = max(1, N - 2): a sensor must agree with all others but one, so one
//   faulty sensor cannot vote out a good one (good ones keep N - 2 votes).
#pragma once

#include <array>
#include <optional>

#include "moa/core/fallback.hpp"
#include "moa/core/noise_model.hpp"
#include "moa/core/options_check.hpp"

namespace moa {

struct SekimoriOptions {
  real e_th = 4e-8;   ///< m^2, on the per-sample displacement residual E_ij
  int r_th = -1;      ///< votes needed; -1 means max(1, N - 2)
  WheelNoise wheels;  ///< only for the covariance reported on wheel samples
  HoldModel hold;
  /// nullopt when usable, else the first field out of its bounds, its path
  /// relative to this struct (options_check.hpp).
  OptionCheck validate() const;
};

class SekimoriEstimator {
 public:
  static std::variant<SekimoriEstimator, GeometryError> create(const SensorArray& array,
                                                               SekimoriOptions options = {});

  std::optional<RobustEstimate> estimate(const ArraySample& sample,
                                         const std::optional<Twist2>& wheels = std::nullopt);

  /// E_ij of eq. (4) for the last sample (m^2).
  real pair_residual(int i, int j) const;
  int r_th() const { return r_th_; }

 private:
  SekimoriEstimator(const SensorArray& array, SekimoriOptions options);

  int n_;
  SekimoriOptions options_;
  int r_th_;
  SubsetSolver solver_;
  std::array<Mat2, kMaxSensors> c_ = zeros<Mat2>();  ///< m per count, robot frame
  std::array<Mat2, kMaxSensors> quant_ = zeros<Mat2>();
  /// Unit normals n_ij (4-vectors), pairs i < j in row-major order.
  std::array<Vec4, kMaxSensors*(kMaxSensors - 1) / 2> normals_{};
  std::array<real, kMaxSensors*(kMaxSensors - 1) / 2> residual_{};
  PointMeasurements measurements_;
  Fallback fallback_;
  int pair_index(int i, int j) const { return i * n_ - i * (i + 1) / 2 + (j - i - 1); }
};

}  // namespace moa
