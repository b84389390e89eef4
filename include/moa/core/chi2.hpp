// Chi-square distribution: the quantiles the consistency tests need.
// Computed once at construction time, never per sample.
#pragma once

namespace moa {

/// P(a, x): the regularised lower incomplete gamma function (series for
/// x < a + 1, Lentz continued fraction otherwise), accurate to ~1e-14.
double regularized_gamma_p(double a, double x);

/// The chi-square CDF with `dof` degrees of freedom: P(dof/2, x/2).
double chi2_cdf(double x, int dof);

/// The x with chi2_cdf(x, dof) = p, by bisection (p in (0, 1), dof >= 1).
double chi2_quantile(double p, int dof);

}  // namespace moa
