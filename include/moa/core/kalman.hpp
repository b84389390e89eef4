// The one gated Kalman update of the core, in the discipline of an aid
// source: a measurement z of the state x through H (z = H x + n,
// n ~ N(0, R)) gives the innovation y = z - H x with variance
// S = H P H^T + R and the test ratio
//   ratio = y^T S^-1 y / gate,   gate = q(1 - alpha, M) (chi2.hpp),
// so 1 is the gate: a measurement over it is inconsistent with the state at
// the false-alarm rate alpha while both are honest. When fused, the state and
// its covariance are updated with the gain K = P H^T S^-1 in Joseph form,
//   x <- x + K y,   P <- (I - K H) P (I - K H)^T + K R K^T,
// which keeps P symmetric and positive semi-definite in single precision
// (the Cortex-M4F build), where the short form (I - K H) P does not.
// Fixed-size Eigen types only: nothing is allocated.
#pragma once

#include <Eigen/LU>

#include "moa/core/real.hpp"

namespace moa {

/// What became of one measurement.
struct AidStatus {
  real test_ratio = 0.0;  ///< y^T S^-1 y / gate
  bool fused = false;
};

/// The test ratio of innovation y with covariance S against `gate`.
template <int M>
real test_ratio(const Mat<M, 1>& y, const Mat<M, M>& s, real gate) {
  return y.dot(s.inverse() * y) / gate;
}

/// S = H P H^T + R. The products here are coefficient-based (lazyProduct):
/// Eigen's blocked product, which it picks for the larger fixed sizes, may
/// take its temporaries from the heap, and the core is heap-free.
template <int N, int M>
Mat<M, M> innovation_covariance(const Mat<N, N>& p, const Mat<M, N>& h, const Mat<M, M>& r) {
  const Mat<M, N> hp = h.lazyProduct(p);
  return hp.lazyProduct(h.transpose()) + r;
}

/// The Joseph-form update above, without a test (a measurement that is to be
/// taken whatever it says, such as the bridge's rotation).
template <int N, int M>
void joseph_update(Mat<N, 1>& x, Mat<N, N>& p, const Mat<M, 1>& y, const Mat<M, N>& h,
                   const Mat<M, M>& r) {
  const Mat<M, M> s = innovation_covariance<N, M>(p, h, r);
  const Mat<N, M> pht = p.lazyProduct(h.transpose());
  const Mat<N, M> k = pht.lazyProduct(s.inverse());
  const Mat<N, N> a = Mat<N, N>::Identity() - k.lazyProduct(h);
  x += k.lazyProduct(y);
  const Mat<N, N> ap = a.lazyProduct(p);
  const Mat<N, M> kr = k.lazyProduct(r);
  p = ap.lazyProduct(a.transpose()) + kr.lazyProduct(k.transpose());
}

/// Tests the measurement, then fuses it when its ratio is at most 1.
template <int N, int M>
AidStatus gated_update(Mat<N, 1>& x, Mat<N, N>& p, const Mat<M, 1>& y, const Mat<M, N>& h,
                       const Mat<M, M>& r, real gate) {
  AidStatus status;
  status.test_ratio = test_ratio<M>(y, innovation_covariance<N, M>(p, h, r), gate);
  if (status.test_ratio <= real(1)) {
    joseph_update<N, M>(x, p, y, h, r);
    status.fused = true;
  }
  return status;
}

}  // namespace moa
