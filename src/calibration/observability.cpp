#include "moa/calibration/observability.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <bit>
#include <vector>

namespace moa {

namespace {

// Priority of keeping at nominal: earlier in this list is kept first.
constexpr std::array<int, kMountParameters> kKeepOrder{4, 3, 2, 0, 1};

bool passes(const MountMatrix& scaled, unsigned subset, const ObservabilityOptions& options,
            double lambda_max) {
  std::vector<int> idx;
  for (int p = 0; p < kMountParameters; ++p)
    if ((subset >> p) & 1u) idx.push_back(p);
  if (idx.empty()) return true;
  Eigen::MatrixXd block(static_cast<Eigen::Index>(idx.size()),
                        static_cast<Eigen::Index>(idx.size()));
  for (std::size_t a = 0; a < idx.size(); ++a)
    for (std::size_t b = 0; b < idx.size(); ++b)
      block(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b)) = scaled(idx[a], idx[b]);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(block, Eigen::EigenvaluesOnly);
  const double lambda_min = eig.eigenvalues()(0);
  return lambda_min >= options.min_information && lambda_min >= options.relative_floor * lambda_max;
}

// Rank of a kept set for tie-breaking: lexicographic in kKeepOrder, so that
// keeping "scale y" is preferred over keeping "scale x", and so on.
unsigned keep_rank(unsigned kept) {
  unsigned rank = 0;
  for (int pos = 0; pos < kMountParameters; ++pos) {
    rank <<= 1;
    if ((kept >> kKeepOrder[static_cast<std::size_t>(pos)]) & 1u) rank |= 1u;
  }
  return rank;
}

}  // namespace

SensorObservability choose_estimated(const MountMatrix& information,
                                     const ObservabilityOptions& options) {
  const MountMatrix d = options.prior_sd.asDiagonal();
  const MountMatrix scaled = d * (0.5 * (information + information.transpose())) * d;
  const Eigen::SelfAdjointEigenSolver<MountMatrix> eig(scaled, Eigen::EigenvaluesOnly);
  SensorObservability out;
  out.scaled_eigenvalues = eig.eigenvalues();
  const double lambda_max = std::max(out.scaled_eigenvalues(kMountParameters - 1), 0.0);

  constexpr unsigned kAll = (1u << kMountParameters) - 1u;
  unsigned best = 0;
  int best_size = -1;
  unsigned best_rank = 0;
  for (unsigned subset = 0; subset <= kAll; ++subset) {
    const int size = std::popcount(subset);
    if (size < best_size) continue;
    const unsigned rank = keep_rank(kAll & ~subset);
    if (size == best_size && rank <= best_rank) continue;
    if (!passes(scaled, subset, options, lambda_max)) continue;
    best = subset;
    best_size = size;
    best_rank = rank;
  }
  for (int p = 0; p < kMountParameters; ++p)
    out.estimated[static_cast<std::size_t>(p)] = (best >> p) & 1u;
  return out;
}

}  // namespace moa
