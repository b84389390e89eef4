// Chi-square distribution: the quantiles the consistency tests need.
// Computed once at construction time, never per sample.
#pragma once

namespace moa {

/// P(a, x): the regularised lower incomplete gamma function (series for
/// x < a + 1, Lentz continued fraction otherwise), accurate to ~1e-14.
double regularized_gamma_p(double a, double x);

/// The chi-square CDF with `dof` degrees of freedom: P(dof/2, x/2).
double chi2_cdf(double x, int dof);

/// Beyond this many degrees of freedom chi2_quantile uses the
/// Wilson-Hilferty approximation (the series of P(a, x) needs about
/// 6 sqrt(a) terms near its median; at 201 dof the approximation's upper
/// 1e-6 quantile leaves a tail within 10 % of 1e-6: test Chi2.QuantilesMatchKnownValues).
inline constexpr int kChi2LargeDof = 200;

/// The x with chi2_cdf(x, dof) = p, by bisection (p in (0, 1), dof >= 1);
/// Wilson-Hilferty beyond kChi2LargeDof.
double chi2_quantile(double p, int dof);

}  // namespace moa
