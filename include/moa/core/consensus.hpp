// The consensus estimator: the largest set of sensors that one rigid-body
// twist explains, by a chi-square test on the whitened residual.
//
// Per sample:
//  1. Point velocities u_i and covariances S_i from the NoiseModel (at the
//     sample's dt, inflated near the rated speed, on low SQUAL or overflow),
//     predicted with the last twist. Sensors that report lift are out.
//  2. For k = candidates down to 2, every subset of k sensors is fitted
//     (SubsetSolver) and passes when chi2 <= q(1 - alpha, 2k - 3). When
//     wheels are present, a subset of at most half the sensors must also
//     agree with them: (x - x_w)^T (Cov + W)^-1 (x - x_w) <= q(1 - alpha, 3),
//     since a minority could agree by chance while the majority is lost.
//     Among the passing subsets of the largest k the smallest chi2 (plus the
//     wheel distance, when present) wins.
//  3. Nothing passes: the wheel twist (source wheels) or, without wheels,
//     the last good twist with its covariance grown (source hold).
// Subsets of each size are enumerated in increasing bit order as they are
// needed (N <= 10, so at most 1013 fits and no table to store); for larger
// arrays the worst sensor is dropped greedily. Per-sample cost does not
// depend on the log's length and nothing is allocated, not even at
// construction (the estimator runs on microcontrollers without a heap).
#pragma once

#include <optional>

#include "moa/core/fallback.hpp"
#include "moa/core/noise_model.hpp"

namespace moa {

struct ConsensusOptions {
  double alpha = 1e-3;  ///< false-rejection rate of the chi-square tests
  NoiseModelOptions noise;
  WheelNoise wheels;
  HoldModel hold;
};

class ConsensusEstimator {
 public:
  static constexpr int kMaxExhaustive = 10;

  /// Refuses arrays that no two sensors can observe (see LsEstimator::create).
  static std::variant<ConsensusEstimator, GeometryError> create(const SensorArray& array,
                                                                ConsensusOptions options = {});

  /// One sample; `wheels` is the wheel twist over the same interval, if any.
  /// Returns nullopt only when dt is not positive and finite.
  std::optional<RobustEstimate> estimate(const ArraySample& sample,
                                         const std::optional<Twist2>& wheels = std::nullopt);

 private:
  ConsensusEstimator(const SensorArray& array, ConsensusOptions options);
  struct Candidate {
    SubsetFit fit;
    SensorMask mask = 0;
    double cost = 0.0;
  };
  std::optional<Candidate> search(SensorMask candidates, const std::optional<Twist2>& wheels,
                                  const Eigen::Matrix3d& wheel_cov) const;
  bool consider(SensorMask mask, const std::optional<Twist2>& wheels,
                const Eigen::Matrix3d& wheel_cov, std::optional<Candidate>& best) const;

  int n_;
  ConsensusOptions options_;
  SubsetSolver solver_;
  NoiseModel noise_;
  std::array<double, 2 * kMaxSensors> threshold_{};  ///< by dof
  double wheel_threshold_ = 0.0;
  // State carried between samples.
  PointMeasurements measurements_;
  Fallback fallback_;
};

}  // namespace moa
