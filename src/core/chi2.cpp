#include "moa/core/chi2.hpp"

#include <cmath>
#include <limits>

namespace moa {

double regularized_gamma_p(double a, double x) {
  if (x <= 0.0) return 0.0;
  const double log_prefix = a * std::log(x) - x - std::lgamma(a);
  if (x < a + 1.0) {
    // P = x^a e^-x / Gamma(a+1) * sum_n x^n / ((a+1)...(a+n))
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < 1000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::abs(term) < std::abs(sum) * 1e-16) break;
    }
    return std::exp(log_prefix) * sum;
  }
  // Q = x^a e^-x / Gamma(a) * 1 / (x + 1 - a - 1(1-a)/(x + 3 - a - ...)), modified Lentz.
  constexpr double kTiny =
      std::numeric_limits<double>::min() / std::numeric_limits<double>::epsilon();
  double b = x + 1.0 - a, c = 1.0 / kTiny, d = 1.0 / b, h = d;
  for (int n = 1; n < 1000; ++n) {
    const double an = -n * (n - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < 1e-16) break;
  }
  return 1.0 - std::exp(log_prefix) * h;
}

double chi2_cdf(double x, int dof) { return regularized_gamma_p(0.5 * dof, 0.5 * x); }

namespace {
/// The standard normal quantile, by bisection on erfc (to 1e-12).
double normal_quantile(double p) {
  double lo = -40.0, hi = 40.0;
  for (int k = 0; k < 200 && hi - lo > 1e-12; ++k) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}
}  // namespace

double chi2_quantile(double p, int dof) {
  if (dof > kChi2LargeDof) {
    // Wilson-Hilferty: (x / dof)^(1/3) is close to normal with mean
    // 1 - 2 / (9 dof) and variance 2 / (9 dof).
    const double a = 2.0 / (9.0 * dof);
    const double c = 1.0 - a + normal_quantile(p) * std::sqrt(a);
    return dof * c * c * c;
  }
  double lo = 0.0, hi = dof + 10.0 * std::sqrt(2.0 * dof) + 100.0;
  while (chi2_cdf(hi, dof) < p) hi *= 2.0;
  for (int k = 0; k < 200 && hi - lo > 1e-12 * hi; ++k) {
    const double mid = 0.5 * (lo + hi);
    (chi2_cdf(mid, dof) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace moa
