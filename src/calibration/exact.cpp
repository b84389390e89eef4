#include "moa/calibration/exact.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/QR>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <unsupported/Eigen/NonLinearOptimization>
#include <utility>

#include "moa/core/chi2.hpp"

namespace moa {

namespace {

// Chi-square(2N) quantile probability above which a sample is an outlier,
// and the largest share of samples that may be rejected as such.
constexpr double kOutlierProbability = 1e-6;
constexpr double kMaxOutlierShare = 0.05;
// Floors of the estimated noise: counts variance (real-valued synthetic
// counts have none), and reference variance relative to the mice-only
// twist variance (the reference is never taken as more than 1000 times
// (in sd) more precise than the mice: keeps W^-1 finite).
constexpr double kMinCountsVariance = 1e-9;
constexpr double kMinReferenceShare = 1e-6;
// Plausible OLS sensor matrix for a start: both scales within this factor of 1.
constexpr double kPlausibleScale = 2.0;

// Per-sample sizes are bounded by kMaxSensors: no heap allocation in the
// residual and Jacobian loops (they run K times per optimiser step).
using CountsVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 2 * kMaxSensors, 1>;
using HMatrix = Eigen::Matrix<double, Eigen::Dynamic, 3, 0, 2 * kMaxSensors, 3>;

struct Data {
  int n = 0;
  Eigen::MatrixXd c;   // 2n x K, counts
  Eigen::MatrixXd w;   // 3 x K, reference displacement w_k dt_k
  Eigen::VectorXd dt;  // K
  Eigen::Index size() const { return dt.size(); }
};

HMatrix stack_h(const std::vector<SensorMount>& mounts) {
  HMatrix h(2 * static_cast<Eigen::Index>(mounts.size()), 3);
  for (std::size_t i = 0; i < mounts.size(); ++i) {
    h.middleRows<2>(2 * static_cast<Eigen::Index>(i)) = mounts[i].twist_jacobian();
  }
  return h;
}

// Whitening of the two noise sources.
struct Weights {
  CountsVector inv_var;         // 2n, 1 / s_i^2 per count row
  CountsVector inv_sd;          // 2n, 1 / s_i
  Eigen::Matrix3d sigma_w_inv;  // Sigma_w^-1
  Eigen::Matrix3d chol_inv;     // L^-1, Sigma_w = L L^T
};

Weights weights_of(const CalibrationNoise& noise, int n) {
  Weights w;
  w.inv_var.resize(2 * n);
  for (int i = 0; i < n; ++i) {
    w.inv_var.segment<2>(2 * i).setConstant(1.0 /
                                            noise.counts_variance[static_cast<std::size_t>(i)]);
  }
  w.inv_sd = w.inv_var.cwiseSqrt();
  const Eigen::LLT<Eigen::Matrix3d> llt(noise.reference_covariance);
  const Eigen::Matrix3d l = llt.matrixL();
  w.chol_inv = l.inverse();
  w.sigma_w_inv = w.chol_inv.transpose() * w.chol_inv;
  return w;
}

Eigen::Matrix3d weighted_normal(const HMatrix& h, const Weights& wt) {
  return h.transpose() * wt.inv_var.asDiagonal() * h;
}

// The normal matrix A_k and z_k of the header for sample k.
struct JointSolution {
  Eigen::LDLT<Eigen::Matrix3d> a;
  Eigen::Vector3d z;
};

JointSolution joint_solution(const HMatrix& h, const Eigen::Matrix3d& htdh, const Weights& wt,
                             const Data& d, Eigen::Index k) {
  const double inv_dt2 = 1.0 / (d.dt(k) * d.dt(k));
  JointSolution s;
  s.a.compute(htdh + wt.sigma_w_inv * inv_dt2);
  const CountsVector weighted = wt.inv_var.cwiseProduct(d.c.col(k));
  const Eigen::Vector3d rhs = h.transpose() * weighted + wt.sigma_w_inv * d.w.col(k) * inv_dt2;
  s.z = s.a.solve(rhs);
  return s;
}

Eigen::Vector3d joint_displacement(const HMatrix& h, const Eigen::Matrix3d& htdh, const Weights& wt,
                                   const Data& d, Eigen::Index k) {
  return joint_solution(h, htdh, wt, d, k).z;
}

void sample_residual(const HMatrix& h, const Eigen::Matrix3d& htdh, const Weights& wt,
                     const Data& d, Eigen::Index k, Eigen::Ref<Eigen::VectorXd> out) {
  const Eigen::Vector3d z = joint_displacement(h, htdh, wt, d, k);
  const Eigen::Index m = 2 * d.n;
  out.head(m) = wt.inv_sd.cwiseProduct(d.c.col(k) - h * z);
  out.tail<3>() = wt.chol_inv * (d.w.col(k) - z) / d.dt(k);
}

struct FreeParameter {
  int sensor;
  int parameter;
};

std::vector<SensorMount> with_free(std::vector<SensorMount> mounts,
                                   const std::vector<FreeParameter>& free,
                                   const Eigen::VectorXd& x) {
  for (std::size_t j = 0; j < free.size(); ++j) {
    SensorMount& m = mounts[static_cast<std::size_t>(free[j].sensor)];
    MountVector p = mount_parameters(m);
    p(free[j].parameter) = x(static_cast<Eigen::Index>(j));
    m = with_mount_parameters(m, p);
  }
  return mounts;
}

// dH_i / d(theta_j) (2x3) of a mount: column c is d(H_i e_c) / d(theta_j),
// the parameter Jacobian at the unit twist e_c (H_i x is linear in x).
std::array<Eigen::Matrix<double, 2, 3>, kMountParameters> h_derivatives(const SensorMount& m) {
  std::array<Eigen::Matrix<double, 2, 3>, kMountParameters> out;
  for (int c = 0; c < 3; ++c) {
    const Eigen::Matrix<double, 2, 5> pj =
        m.parameter_jacobian(Twist2::from_vector(Eigen::Vector3d::Unit(c)));
    for (int j = 0; j < kMountParameters; ++j) out[static_cast<std::size_t>(j)].col(c) = pj.col(j);
  }
  return out;
}

// The least-squares problem of the header for Eigen's Levenberg-Marquardt
// (the optimum-storage variant asks for the Jacobian one row at a time).
//
// Jacobian, analytic: only H depends on theta. For a parameter of sensor i
// with dH_i = Delta (2x3), differentiating A z = H^T D^-1 c + W^-1 w dt gives
//   dz = A^-1 (Delta^T r_i - H_i^T Delta z) / s_i^2,   r = c - H z,
//   d rho_top = -D^-1/2 (dH z + H dz),   d rho_bottom = -W^-1/2 dz.
struct EivFunctor {
  using Scalar = double;
  enum { InputsAtCompileTime = Eigen::Dynamic, ValuesAtCompileTime = Eigen::Dynamic };
  using InputType = Eigen::VectorXd;
  using ValueType = Eigen::VectorXd;
  using JacobianType = Eigen::MatrixXd;

  EivFunctor(const Data& d, const Weights& w, std::vector<SensorMount> mounts,
             std::vector<FreeParameter> f)
      : data(d), wt(w), base(std::move(mounts)), free(std::move(f)) {}

  const Data& data;
  const Weights& wt;
  std::vector<SensorMount> base;
  std::vector<FreeParameter> free;

  // Jacobian pass cache: H, H^T D^-1 H and dH per free parameter at the
  // pass's x, and the current sample's block of rows.
  HMatrix h;
  Eigen::Matrix3d htdh;
  std::vector<Eigen::Matrix<double, 2, 3>> delta;
  Eigen::Index block_sample = -1;
  Eigen::MatrixXd block;

  int rows_per_sample() const { return 2 * data.n + 3; }
  int inputs() const { return static_cast<int>(free.size()); }
  int values() const { return rows_per_sample() * static_cast<int>(data.size()); }

  int operator()(const Eigen::VectorXd& x, Eigen::VectorXd& f) const {
    const HMatrix hx = stack_h(with_free(base, free, x));
    const Eigen::Matrix3d nx = weighted_normal(hx, wt);
    const int r = rows_per_sample();
    for (Eigen::Index k = 0; k < data.size(); ++k) {
      sample_residual(hx, nx, wt, data, k, f.segment(k * r, r));
    }
    return 0;
  }

  int df(const Eigen::VectorXd& x, Eigen::VectorXd& jac_row, Eigen::Index rownb) {
    const Eigen::Index row = rownb - 2;  // MINPACK numbers rows from 2 here
    const int r = rows_per_sample();
    if (row == 0) prepare(x);
    const Eigen::Index k = row / r;
    if (k != block_sample) {
      fill_block(k);
      block_sample = k;
    }
    jac_row = block.row(row % r).transpose();
    return 0;
  }

  void prepare(const Eigen::VectorXd& x) {
    const std::vector<SensorMount> mounts = with_free(base, free, x);
    h = stack_h(mounts);
    htdh = weighted_normal(h, wt);
    delta.resize(free.size());
    for (std::size_t j = 0; j < free.size(); ++j) {
      delta[j] = h_derivatives(mounts[static_cast<std::size_t>(
          free[j].sensor)])[static_cast<std::size_t>(free[j].parameter)];
    }
    block.resize(rows_per_sample(), inputs());
    block_sample = -1;
  }

  void fill_block(Eigen::Index k) {
    const JointSolution s = joint_solution(h, htdh, wt, data, k);
    const CountsVector res = data.c.col(k) - h * s.z;
    const Eigen::Index m = 2 * data.n;
    const double inv_dt = 1.0 / data.dt(k);
    for (std::size_t j = 0; j < free.size(); ++j) {
      const int i = free[j].sensor;
      const double inv_var = wt.inv_var(2 * i);
      const Eigen::Matrix<double, 2, 3>& dh = delta[j];
      const Eigen::Vector2d dh_z = dh * s.z;
      const Eigen::Vector3d dz = s.a.solve(
          (dh.transpose() * res.segment<2>(2 * i) - h.middleRows<2>(2 * i).transpose() * dh_z) *
          inv_var);
      CountsVector top = -(h * dz);
      top.segment<2>(2 * i) -= dh_z;
      const auto col = static_cast<Eigen::Index>(j);
      block.col(col).head(m) = wt.inv_sd.cwiseProduct(top);
      block.col(col).tail<3>() = -(wt.chol_inv * dz) * inv_dt;
    }
  }
};

// Noise levels from the data at the current mounts (header comment).
CalibrationNoise estimate_noise(const std::vector<SensorMount>& mounts, const Data& d,
                                bool errors_in_variables, bool remove_misfit) {
  const int n = d.n;
  const auto kk = static_cast<double>(d.size());
  const HMatrix h = stack_h(mounts);
  CalibrationNoise noise;
  // One variance for all count rows: the mice-only least-squares residual
  // has 2N - 3 degrees of freedom per sample. (Per-sensor variances from the
  // same residuals are a fixed point that can collapse onto one sensor when
  // the noise is far from isotropic, e.g. an axis that does not move and so
  // has no quantisation noise at all.)
  const Eigen::Matrix3d hth_inv = (h.transpose() * h).inverse();
  const Eigen::MatrixXd z = hth_inv * h.transpose() * d.c;
  const double variance =
      std::max((d.c - h * z).squaredNorm() / (kk * (2.0 * n - 3.0)), kMinCountsVariance);
  noise.counts_variance.assign(static_cast<std::size_t>(n), variance);
  const Eigen::Matrix3d p = variance * hth_inv;

  const Eigen::MatrixXd dz = d.w - z;
  const double sum_dt2 = d.dt.squaredNorm();
  const double floor = std::max(kMinReferenceShare * p.trace() / 3.0 / (sum_dt2 / kk), 1e-30);
  Eigen::Matrix3d sigma = Eigen::Matrix3d::Identity() * floor;
  if (errors_in_variables && remove_misfit) {
    // At a start far from the truth, the part of w - z~ linear in z~ is the
    // geometry's misfit, not reference noise: regressed out, a wrong start
    // cannot pass its misfit off as noise (which would make the fit trust
    // the reference too little and stay near the start). Only for the start:
    // a regressor without signal (v under pure rotation) would take the noise
    // with it.
    const Eigen::Matrix3d zz = z * z.transpose();
    const Eigen::CompleteOrthogonalDecomposition<Eigen::Matrix3d> cod(zz);
    const Eigen::MatrixXd resid = dz - (dz * z.transpose()) * cod.pseudoInverse() * z;
    const double dof = std::max(kk - static_cast<double>(cod.rank()), 1.0);
    sigma = (resid * resid.transpose() * (kk / dof) - kk * p) / sum_dt2;
  } else if (errors_in_variables) {
    sigma = (dz * dz.transpose() - kk * p) / sum_dt2;
  }
  if (errors_in_variables) {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(0.5 * (sigma + sigma.transpose()));
    const Eigen::Vector3d lambda = eig.eigenvalues().cwiseMax(floor);
    sigma = eig.eigenvectors() * lambda.asDiagonal() * eig.eigenvectors().transpose();
  }
  noise.reference_covariance = sigma;
  return noise;
}

// F of the header. G_k is linear in z_k, G_k = sum_c z_kc G_c (G_c: G at
// the unit twist e_c), so
//   F = sum_{c,d} sum_k s_kcd (G_c^T D^-1 G_d - B_c^T A_k^-1 B_d),   B_c = H^T D^-1 G_c,
// with s_k = z_k z_k^T. Given two independent noisy views of z_k (`za`,
// `zb`: the reference and the mice alone), s_k = sym(za_k zb_k^T) is
// unbiased for z_k z_k^T whatever either's noise; za_k za_k^T would count
// that view's noise as excitation (under a pure rotation the mice's noise
// in v would seem to excite yaw and scale).
Eigen::MatrixXd information_at(const std::vector<SensorMount>& mounts, const Eigen::MatrixXd& za,
                               const Eigen::MatrixXd& zb, const Eigen::VectorXd& dt,
                               const CalibrationNoise& noise) {
  const auto n = static_cast<int>(mounts.size());
  const Weights wt = weights_of(noise, n);
  const HMatrix h = stack_h(mounts);
  const Eigen::Matrix3d htdh = weighted_normal(h, wt);
  const int p = kMountParameters * n;

  std::array<Eigen::MatrixXd, 3> b;                   // B_c
  std::array<std::array<Eigen::MatrixXd, 3>, 3> gdg;  // G_c^T D^-1 G_d
  for (int c = 0; c < 3; ++c) {
    b[static_cast<std::size_t>(c)] = Eigen::MatrixXd::Zero(3, p);
    for (int e = 0; e < 3; ++e)
      gdg[static_cast<std::size_t>(c)][static_cast<std::size_t>(e)] = Eigen::MatrixXd::Zero(p, p);
  }
  for (int i = 0; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    const double inv_var = 1.0 / noise.counts_variance[u];
    std::array<Eigen::Matrix<double, 2, 5>, 3> g;
    for (int c = 0; c < 3; ++c) {
      g[static_cast<std::size_t>(c)] =
          mounts[u].parameter_jacobian(Twist2::from_vector(Eigen::Vector3d::Unit(c)));
    }
    for (int c = 0; c < 3; ++c) {
      const auto cu = static_cast<std::size_t>(c);
      b[cu].middleCols<5>(5 * i) = inv_var * h.middleRows<2>(2 * i).transpose() * g[cu];
      for (int e = 0; e < 3; ++e) {
        const auto eu = static_cast<std::size_t>(e);
        gdg[cu][eu].block<5, 5>(5 * i, 5 * i) = inv_var * g[cu].transpose() * g[eu];
      }
    }
  }

  Eigen::Matrix3d s_sum = Eigen::Matrix3d::Zero();
  std::array<std::array<Eigen::Matrix3d, 3>, 3> q{};
  for (auto& row : q)
    for (auto& m : row) m.setZero();
  for (Eigen::Index k = 0; k < za.cols(); ++k) {
    const Eigen::Matrix3d a_inv = (htdh + wt.sigma_w_inv / (dt(k) * dt(k))).inverse();
    const Eigen::Matrix3d cross = za.col(k) * zb.col(k).transpose();
    const Eigen::Matrix3d s_k = 0.5 * (cross + cross.transpose());
    s_sum += s_k;
    for (int c = 0; c < 3; ++c)
      for (int e = 0; e < 3; ++e)
        q[static_cast<std::size_t>(c)][static_cast<std::size_t>(e)] += s_k(c, e) * a_inv;
  }
  Eigen::MatrixXd f = Eigen::MatrixXd::Zero(p, p);
  for (int c = 0; c < 3; ++c) {
    const auto cu = static_cast<std::size_t>(c);
    for (int e = 0; e < 3; ++e) {
      const auto eu = static_cast<std::size_t>(e);
      f += s_sum(c, e) * gdg[cu][eu] - b[cu].transpose() * q[cu][eu] * b[eu];
    }
  }
  return 0.5 * (f + f.transpose());
}

Eigen::MatrixXd joint_displacements(const std::vector<SensorMount>& mounts, const Data& d,
                                    const CalibrationNoise& noise) {
  const Weights wt = weights_of(noise, d.n);
  const HMatrix h = stack_h(mounts);
  const Eigen::Matrix3d htdh = weighted_normal(h, wt);
  Eigen::MatrixXd z(3, d.size());
  for (Eigen::Index k = 0; k < d.size(); ++k) z.col(k) = joint_displacement(h, htdh, wt, d, k);
  return z;
}

// The chi-square quantile of 1 - kOutlierProbability at `dof` (core/chi2).
double outlier_quantile(double dof) {
  return chi2_quantile(1.0 - kOutlierProbability, static_cast<int>(std::lround(dof)));
}

// The model check (ExactModelCheck in the header). Counts are integers: no
// model predicts them better than their rounding, 1/12 count^2 per axis
// (the floor also keeps noise-free synthetic counts from dividing by ~0).
constexpr double kCountRoundingVariance = 1.0 / 12.0;
// A residual variance more than this many times the counts' own noise is
// a misfit whatever the sample size: the RMS is twice the noise.
constexpr double kMisfitVarianceRatio = 4.0;
// Fewest degrees of freedom of the noise s0^2 to test against (its
// relative 1-sigma sqrt(2 / 30) = 0.26 is far below the factor 4).
constexpr double kMinNoiseDof = 30.0;

ExactModelCheck check_model(const std::vector<SensorMount>& mounts, const Data& d,
                            const std::vector<SensorObservability>& obs) {
  ExactModelCheck check;
  const auto kk = static_cast<double>(d.size());
  const double per_sample = 2.0 * d.n - 3.0;  // count rows beyond the twist's 3
  // s^2: the mice-only least-squares residual at the mounts.
  const HMatrix h = stack_h(mounts);
  const Eigen::MatrixXd z = (h.transpose() * h).inverse() * h.transpose() * d.c;
  check.residual_variance = (d.c - h * z).squaredNorm() / (kk * per_sample);
  // s0^2: the 2N - 3 smallest eigenvalues of C C^T (C the 2N x K counts)
  // are what no rank-3 fit (no rigid motion seen through any H) explains.
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(d.c * d.c.transpose(),
                                                           Eigen::EigenvaluesOnly);
  const Eigen::VectorXd lambda = eig.eigenvalues();  // ascending
  const double free_residual = lambda.head(2 * d.n - 3).cwiseMax(0.0).sum();
  const double noise_dof = (kk - 3.0) * per_sample;
  check.noise_variance =
      std::max(noise_dof > 0.0 ? free_residual / noise_dof : 0.0, kCountRoundingVariance);
  const double dof = kk * per_sample;
  check.bound = std::max(kMisfitVarianceRatio, outlier_quantile(dof) / dof);
  check.tested = noise_dof >= kMinNoiseDof;
  check.min_eigenvalue = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < obs.size(); ++i) {
    const double lambda_min = obs[i].scaled_eigenvalues.minCoeff();
    if (lambda_min < check.min_eigenvalue) {
      check.min_eigenvalue = lambda_min;
      check.min_eigenvalue_sensor = static_cast<int>(i);
    }
  }
  return check;
}

Data select(const Data& d, const std::vector<bool>& keep) {
  Data out;
  out.n = d.n;
  const auto m = static_cast<Eigen::Index>(std::count(keep.begin(), keep.end(), true));
  out.c.resize(d.c.rows(), m);
  out.w.resize(3, m);
  out.dt.resize(m);
  Eigen::Index j = 0;
  for (Eigen::Index k = 0; k < d.size(); ++k) {
    if (!keep[static_cast<std::size_t>(k)]) continue;
    out.c.col(j) = d.c.col(k);
    out.w.col(j) = d.w.col(k);
    out.dt(j) = d.dt(k);
    ++j;
  }
  return out;
}

struct Fit {
  std::vector<SensorMount> mounts;
  CalibrationNoise noise;
  bool converged = false;
  int iterations = 0;
};

// Outer loop: LM on the free parameters, then the noise again, until both settle.
Fit fit(const Data& d, std::vector<SensorMount> mounts, const std::vector<FreeParameter>& free,
        CalibrationNoise noise, const ExactOptions& options) {
  Fit out;
  const MountVector& prior = options.observability.prior_sd;
  for (int iter = 0; iter < options.max_iterations; ++iter) {
    out.iterations = iter + 1;
    bool lm_ok = true;
    double step = 0.0;
    if (!free.empty()) {
      const Weights wt = weights_of(noise, d.n);
      EivFunctor functor(d, wt, mounts, free);
      Eigen::VectorXd x(static_cast<Eigen::Index>(free.size()));
      for (std::size_t j = 0; j < free.size(); ++j) {
        x(static_cast<Eigen::Index>(j)) =
            mount_parameters(mounts[static_cast<std::size_t>(free[j].sensor)])(free[j].parameter);
      }
      const Eigen::VectorXd x0 = x;
      Eigen::LevenbergMarquardt<EivFunctor> lm(functor);
      lm.parameters.ftol = 1e-10;
      lm.parameters.xtol = 1e-10;
      lm.parameters.maxfev = 400;
      const auto status = lm.minimizeOptimumStorage(x);
      lm_ok = status != Eigen::LevenbergMarquardtSpace::ImproperInputParameters &&
              status != Eigen::LevenbergMarquardtSpace::TooManyFunctionEvaluation && x.allFinite();
      if (!x.allFinite()) x = x0;
      mounts = with_free(mounts, free, x);
      for (std::size_t j = 0; j < free.size(); ++j) {
        const auto jj = static_cast<Eigen::Index>(j);
        step = std::max(step, std::abs(x(jj) - x0(jj)) / prior(free[j].parameter));
      }
    }
    double noise_change = 0.0;
    if (!options.noise) {
      const CalibrationNoise next = estimate_noise(mounts, d, options.errors_in_variables, false);
      for (std::size_t i = 0; i < next.counts_variance.size(); ++i) {
        noise_change = std::max(noise_change,
                                std::abs(next.counts_variance[i] / noise.counts_variance[i] - 1.0));
      }
      const double ref_scale = noise.reference_covariance.diagonal().maxCoeff();
      noise_change =
          std::max(noise_change,
                   (next.reference_covariance - noise.reference_covariance).cwiseAbs().maxCoeff() /
                       ref_scale);
      noise = next;
    }
    out.converged = lm_ok;
    if (lm_ok && step < 1e-5 && noise_change < 1e-2) break;
  }
  out.mounts = std::move(mounts);
  out.noise = std::move(noise);
  return out;
}

std::vector<FreeParameter> free_parameters(const std::vector<SensorObservability>& obs) {
  std::vector<FreeParameter> free;
  for (std::size_t i = 0; i < obs.size(); ++i) {
    for (int p = 0; p < kMountParameters; ++p) {
      if (obs[i].estimated[static_cast<std::size_t>(p)]) free.push_back({static_cast<int>(i), p});
    }
  }
  return free;
}

std::vector<SensorObservability> decide(const std::vector<SensorMount>& mounts, const Data& d,
                                        const CalibrationNoise& noise,
                                        const ObservabilityOptions& options) {
  const HMatrix h = stack_h(mounts);
  const Eigen::MatrixXd mice_only = (h.transpose() * h).inverse() * h.transpose() * d.c;
  const Eigen::MatrixXd f = information_at(mounts, d.w, mice_only, d.dt, noise);
  std::vector<SensorObservability> obs;
  for (int i = 0; i < d.n; ++i) {
    obs.push_back(choose_estimated(f.block<5, 5>(5 * i, 5 * i), options));
  }
  return obs;
}

// Start: per sensor, the OLS fit split into its parts where it gives a
// plausible sensor matrix (this is where mirroring is found), else nominal.
std::vector<SensorMount> initial_mounts(const Data& d, const SensorArray& nominal,
                                        std::vector<bool>& from_data) {
  std::vector<SensorMount> start(nominal.mounts().begin(), nominal.mounts().end());
  std::fill(from_data.begin(), from_data.end(), false);
  const Eigen::Matrix3d gram = d.w * d.w.transpose();
  const Eigen::FullPivLU<Eigen::Matrix3d> gram_lu(gram);
  if (!gram_lu.isInvertible()) return start;
  const Eigen::MatrixXd theta = d.c * d.w.transpose() * gram_lu.inverse();  // 2n x 3
  for (int i = 0; i < d.n; ++i) {
    SensorMount& m = start[static_cast<std::size_t>(i)];
    const Eigen::Matrix2d mi = theta.block<2, 2>(2 * i, 0);
    const auto parts = decompose_sensor_matrix(mi, m.counts_per_metre());
    if (!parts || !(parts->scale.minCoeff() > 1.0 / kPlausibleScale) ||
        !(parts->scale.maxCoeff() < kPlausibleScale)) {
      continue;
    }
    SensorMount candidate = m;
    candidate.yaw = parts->yaw;
    candidate.scale = parts->scale;
    candidate.mirrored = parts->mirrored;
    const Eigen::Vector2d p = position_from_rotation_response(
        candidate.counts_from_robot_velocity(), theta.block<2, 1>(2 * i, 2));
    if (p.allFinite()) candidate.position = p;
    m = candidate;
    from_data[static_cast<std::size_t>(i)] = true;
  }
  return start;
}

}  // namespace

Eigen::MatrixXd calibration_information(const SensorArray& array, std::span<const Twist2> twists,
                                        std::span<const double> dt, const CalibrationNoise& noise) {
  Eigen::MatrixXd z(3, static_cast<Eigen::Index>(twists.size()));
  Eigen::VectorXd d(static_cast<Eigen::Index>(dt.size()));
  for (std::size_t k = 0; k < twists.size(); ++k) {
    z.col(static_cast<Eigen::Index>(k)) = twists[k].vector() * dt[k];
    d(static_cast<Eigen::Index>(k)) = dt[k];
  }
  return information_at({array.mounts().begin(), array.mounts().end()}, z, z, d, noise);
}

std::variant<ExactCalibration, CalibrationError> calibrate_exact(
    const SensorArray& nominal, std::span<const CalibrationSample> samples,
    const ExactOptions& options) {
  if (const auto error = check_nominal(nominal)) return *error;
  const int n = nominal.size();
  if (options.noise && options.noise->counts_variance.size() != static_cast<std::size_t>(n)) {
    return CalibrationError::kBadInput;
  }

  ExactCalibration result;
  std::vector<const CalibrationSample*> used;
  for (const auto& s : samples) {
    if (s.mice.size != n) return CalibrationError::kTooManySensors;
    if (usable_sample(s, n)) {
      used.push_back(&s);
    } else {
      ++result.samples_unusable;
    }
  }
  if (used.size() < 3) return CalibrationError::kTooFewSamples;

  Data all;
  all.n = n;
  const auto kk = static_cast<Eigen::Index>(used.size());
  all.c.resize(2 * n, kk);
  all.w.resize(3, kk);
  all.dt.resize(kk);
  for (Eigen::Index k = 0; k < kk; ++k) {
    const CalibrationSample& s = *used[static_cast<std::size_t>(k)];
    for (int i = 0; i < n; ++i)
      all.c.block<2, 1>(2 * i, k) = s.mice.counts[static_cast<std::size_t>(i)];
    all.dt(k) = s.mice.dt;
    all.w.col(k) = s.reference.vector() * s.mice.dt;
  }
  if (all.w.squaredNorm() == 0.0) return CalibrationError::kNoMotion;

  std::vector<bool> from_data(static_cast<std::size_t>(n), false);
  // Parameters the data do not excite stay at nominal, and so does the
  // mirroring unless yaw and both scales are estimated.
  const auto keep_unexcited = [&](std::vector<SensorMount>& mounts,
                                  const std::vector<SensorObservability>& obs) {
    for (int i = 0; i < n; ++i) {
      const auto u = static_cast<std::size_t>(i);
      const SensorObservability& o = obs[u];
      if (!(o.estimated[2] && o.estimated[3] && o.estimated[4])) {
        mounts[u].mirrored = nominal[i].mirrored;
        from_data[u] = false;
      }
      MountVector p = mount_parameters(mounts[u]);
      const MountVector p0 = mount_parameters(nominal[i]);
      for (int j = 0; j < kMountParameters; ++j) {
        if (!o.estimated[static_cast<std::size_t>(j)]) p(j) = p0(j);
      }
      mounts[u] = with_mount_parameters(mounts[u], p);
    }
  };
  const auto same_choice = [&](const std::vector<SensorObservability>& a,
                               const std::vector<SensorObservability>& b) {
    for (int i = 0; i < n; ++i) {
      if (a[static_cast<std::size_t>(i)].estimated != b[static_cast<std::size_t>(i)].estimated) {
        return false;
      }
    }
    return true;
  };

  Data data = all;
  Fit current;
  std::vector<SensorObservability> obs;
  for (int pass = 0; pass < 3; ++pass) {
    std::vector<SensorMount> start = initial_mounts(data, nominal, from_data);
    CalibrationNoise noise = options.noise
                                 ? *options.noise
                                 : estimate_noise(start, data, options.errors_in_variables, true);
    obs = decide(start, data, noise, options.observability);
    keep_unexcited(start, obs);
    if (!options.noise) noise = estimate_noise(start, data, options.errors_in_variables, true);
    current = fit(data, start, free_parameters(obs), noise, options);

    // Observability again at the estimate (the start's noise levels were
    // inflated by the nominal geometry's misfit); a change means one more fit.
    const std::vector<SensorObservability> again =
        decide(current.mounts, data, current.noise, options.observability);
    if (!same_choice(again, obs)) {
      obs = again;
      keep_unexcited(current.mounts, obs);
      current = fit(data, current.mounts, free_parameters(obs), current.noise, options);
    }

    // Outliers, at most kMaxOutlierShare of the samples; then start afresh
    // from the cleaned data (an outlier can spoil the OLS start, mirroring
    // included).
    if (!options.reject_outliers || pass == 2) break;
    const Weights wt = weights_of(current.noise, n);
    const HMatrix h = stack_h(current.mounts);
    const Eigen::Matrix3d htdh = weighted_normal(h, wt);
    const double limit = outlier_quantile(2.0 * n);
    std::vector<bool> keep(static_cast<std::size_t>(data.size()), true);
    Eigen::VectorXd rho(2 * n + 3);
    int rejected = 0;
    for (Eigen::Index k = 0; k < data.size(); ++k) {
      sample_residual(h, htdh, wt, data, k, rho);
      if (rho.squaredNorm() > limit) {
        keep[static_cast<std::size_t>(k)] = false;
        ++rejected;
      }
    }
    if (rejected == 0) break;
    if (static_cast<double>(rejected) > kMaxOutlierShare * static_cast<double>(data.size()) ||
        data.size() - rejected < 3) {
      result.model_misfit = true;
      break;
    }
    data = select(data, keep);
    result.samples_rejected += rejected;
  }

  // Covariance: F^-1 over the estimated parameters.
  const Eigen::MatrixXd z = joint_displacements(current.mounts, data, current.noise);
  const Eigen::MatrixXd f = information_at(current.mounts, z, z, data.dt, current.noise);
  const std::vector<FreeParameter> free = free_parameters(obs);
  result.covariance = Eigen::MatrixXd::Zero(kMountParameters * n, kMountParameters * n);
  if (!free.empty()) {
    const auto m = static_cast<Eigen::Index>(free.size());
    Eigen::MatrixXd ff(m, m);
    for (Eigen::Index a = 0; a < m; ++a) {
      for (Eigen::Index b = 0; b < m; ++b) {
        const auto& fa = free[static_cast<std::size_t>(a)];
        const auto& fb = free[static_cast<std::size_t>(b)];
        ff(a, b) = f(5 * fa.sensor + fa.parameter, 5 * fb.sensor + fb.parameter);
      }
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(ff);
    const Eigen::VectorXd lambda = eig.eigenvalues();
    const double cut = lambda.maxCoeff() * 1e-14;
    Eigen::VectorXd inv = Eigen::VectorXd::Zero(m);
    for (Eigen::Index j = 0; j < m; ++j)
      if (lambda(j) > cut) inv(j) = 1.0 / lambda(j);
    const Eigen::MatrixXd cov =
        eig.eigenvectors() * inv.asDiagonal() * eig.eigenvectors().transpose();
    for (Eigen::Index a = 0; a < m; ++a) {
      for (Eigen::Index b = 0; b < m; ++b) {
        const auto& fa = free[static_cast<std::size_t>(a)];
        const auto& fb = free[static_cast<std::size_t>(b)];
        result.covariance(5 * fa.sensor + fa.parameter, 5 * fb.sensor + fb.parameter) = cov(a, b);
      }
    }
  }

  // Per-sensor results.
  const HMatrix h = stack_h(current.mounts);
  std::vector<SensorMount> out_mounts = current.mounts;
  for (int i = 0; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    // The yaw nearest the nominal's representation: a config that says 225 deg
    // gets 227 deg back, not -133 deg (and a yaw kept at nominal is unchanged).
    out_mounts[u].yaw = nominal[i].yaw + wrap_angle(out_mounts[u].yaw - nominal[i].yaw);
    SensorCalibration s;
    s.nominal = nominal[i];
    s.calibrated = out_mounts[u];
    s.estimated = obs[u].estimated;
    s.scaled_eigenvalues = obs[u].scaled_eigenvalues;
    s.mirror_from_data =
        from_data[u] && obs[u].estimated[2] && obs[u].estimated[3] && obs[u].estimated[4];
    s.covariance = result.covariance.block<5, 5>(5 * i, 5 * i);
    const Eigen::Matrix2d to_velocity = current.mounts[u].robot_velocity_from_counts();
    double sum = 0.0;
    for (Eigen::Index k = 0; k < data.size(); ++k) {
      const Eigen::Vector2d e = data.c.block<2, 1>(2 * i, k) - h.middleRows<2>(2 * i) * z.col(k);
      sum += (to_velocity * e / data.dt(k)).squaredNorm();
    }
    s.residual_rms = std::sqrt(sum / static_cast<double>(data.size()));
    result.sensors.push_back(s);
  }
  result.check = check_model(current.mounts, data, obs);
  result.calibrated = SensorArray(out_mounts);
  result.noise = current.noise;
  result.samples_used = static_cast<int>(data.size());
  result.converged = current.converged;
  result.iterations = current.iterations;
  return result;
}

}  // namespace moa
