#include "moa/calibration/guided.hpp"

#include <Eigen/LU>
#include <cmath>
#include <functional>
#include <numbers>
#include <unsupported/Eigen/NonLinearOptimization>
#include <unsupported/Eigen/NumericalDiff>

namespace moa {

OptionCheck GuidedTolerances::validate() const {
  return OptionsCheck()
      .positive("distance_sd", distance_sd)
      .positive("turn_sd", turn_sd)
      .positive("centre_sd", centre_sd)
      .positive("heading_sd", heading_sd)
      .positive("anisotropy_sd", anisotropy_sd)
      .result();
}

namespace {

// Least squares fit of (yaw, sx, sy) to a measured sensor matrix
// (SensorMount::counts_from_robot_velocity), mirroring and cpi fixed.
struct MatrixFit {
  using Scalar = double;
  enum { InputsAtCompileTime = Eigen::Dynamic, ValuesAtCompileTime = Eigen::Dynamic };
  using InputType = Eigen::VectorXd;
  using ValueType = Eigen::VectorXd;
  using JacobianType = Eigen::MatrixXd;

  Eigen::Matrix2d target;
  SensorMount mount;  ///< cpi and mirroring as fitted; yaw and scale from x

  int inputs() const { return 3; }
  int values() const { return 4; }
  int operator()(const Eigen::VectorXd& x, Eigen::VectorXd& f) const {
    SensorMount m = mount;
    m.yaw = x(0);
    m.scale = x.tail<2>();
    // In units of counts per metre, so that the residuals are O(1).
    const Eigen::Matrix2d e = (m.counts_from_robot_velocity() - target) / m.counts_per_metre();
    f = Eigen::Map<const Eigen::Vector4d>(e.data());
    return 0;
  }
};

struct Directions {
  bool push_x_reversed = false;
  bool push_y_reversed = false;
  bool spin_clockwise = false;
};

struct Solution {
  std::vector<SensorMount> mounts;
  std::vector<double> misfit;          // m
  std::vector<bool> flipped;           // without push-y: mirroring opposite to nominal
  std::vector<bool> mirror_from_data;  // mirroring decided by the data
};

// Without push-y, M e_x = k s (cos yaw, -f sin yaw) fits f = 1 with yaw and
// f = -1 with -yaw alike; the spin then puts the sensor at two different
// places. The mirroring whose position is nearer the nominal one is taken
// when it is clearly nearer (the other at least twice as far and 5 mm
// farther); else the nominal mirroring stays.
constexpr double kMirrorMargin = 0.005;

// `flips`: the mirroring decisions of an earlier solution to keep (when
// propagating tolerances), or null to decide.
std::optional<Solution> solve(const SensorArray& nominal, const GuidedInput& in,
                              const Directions& dir, const std::vector<bool>* flips,
                              double anisotropy = 1.0) {
  const int n = nominal.size();
  const double dx = dir.push_x_reversed ? -in.distance : in.distance;
  const double dy = dir.push_y_reversed ? -in.distance : in.distance;
  const double angle = 2.0 * std::numbers::pi * in.turns * (dir.spin_clockwise ? -1.0 : 1.0);
  Solution out;
  for (int i = 0; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    SensorMount m = nominal[i];
    const double k = m.counts_per_metre();
    const Eigen::Vector2d ax = in.push_x[u] / dx;
    double misfit = 0.0;
    if (in.push_y) {
      Eigen::Matrix2d measured;
      measured.col(0) = ax;
      measured.col(1) = (*in.push_y)[u] / dy;
      const auto parts = decompose_sensor_matrix(measured, k);
      if (!parts) return std::nullopt;
      SensorMount fitted = m;
      fitted.mirrored = parts->mirrored;
      MatrixFit functor{measured, fitted};
      Eigen::NumericalDiff<MatrixFit, Eigen::Central> diff(functor);
      Eigen::LevenbergMarquardt<Eigen::NumericalDiff<MatrixFit, Eigen::Central>> lm(diff);
      lm.parameters.ftol = 1e-14;
      lm.parameters.xtol = 1e-14;
      Eigen::VectorXd x(3);
      x << parts->yaw, parts->scale.x(), parts->scale.y();
      lm.minimize(x);
      if (!x.allFinite()) return std::nullopt;
      m.yaw += wrap_angle(x(0) - m.yaw);  // nearest the nominal's representation
      m.scale = x.tail<2>();
      m.mirrored = parts->mirrored;
      Eigen::VectorXd f(4);
      functor(x, f);
      misfit = std::sqrt(f.squaredNorm() / 4.0) * in.distance;
    } else {
      // M e_x = k sx (cos yaw, -f rho sin yaw), rho = sy / sx assumed.
      const Eigen::Vector2d a(ax.x(), ax.y() / anisotropy);
      const double s = a.norm() / k;
      if (!(s > 0.0) || !std::isfinite(s)) return std::nullopt;
      const auto candidate = [&](bool mirrored) {
        SensorMount c = m;
        c.mirrored = mirrored;
        c.scale = {s, s * anisotropy};
        c.yaw += wrap_angle(std::atan2(-(mirrored ? -1.0 : 1.0) * a.y(), a.x()) - c.yaw);
        c.position =
            position_from_rotation_response(c.counts_from_robot_velocity(), in.spin[u] / angle);
        return c;
      };
      const SensorMount same = candidate(m.mirrored);
      const SensorMount flipped = candidate(!m.mirrored);
      const double d_same = (same.position - m.position).norm();
      const double d_flipped = (flipped.position - m.position).norm();
      const double near = std::min(d_same, d_flipped);
      const double far = std::max(d_same, d_flipped);
      const bool decided = far > 2.0 * near && far > near + kMirrorMargin;
      const bool flip = flips ? bool((*flips)[u]) : decided && d_flipped < d_same;
      m = flip ? flipped : same;
      out.flipped.push_back(flip);
      out.mirror_from_data.push_back(decided);
    }
    if (in.push_y) {
      const Eigen::Vector2d q = in.spin[u] / angle;
      m.position = position_from_rotation_response(m.counts_from_robot_velocity(), q);
      out.flipped.push_back(false);
      out.mirror_from_data.push_back(true);
    }
    if (!m.position.allFinite() || !m.scale.allFinite()) return std::nullopt;
    out.mounts.push_back(m);
    out.misfit.push_back(misfit);
  }
  return out;
}

Eigen::VectorXd stacked(const std::vector<SensorMount>& mounts) {
  Eigen::VectorXd x(kMountParameters * static_cast<Eigen::Index>(mounts.size()));
  for (std::size_t i = 0; i < mounts.size(); ++i) {
    x.segment<kMountParameters>(kMountParameters * static_cast<Eigen::Index>(i)) =
        mount_parameters(mounts[i]);
  }
  return x;
}

}  // namespace

std::variant<GuidedCalibration, CalibrationError> calibrate_guided(
    const SensorArray& nominal, const GuidedInput& input, const GuidedTolerances& tolerances) {
  if (const auto error = check_nominal(nominal)) return *error;
  const auto n = static_cast<std::size_t>(nominal.size());
  if (input.push_x.size() != n || input.spin.size() != n ||
      (input.push_y && input.push_y->size() != n)) {
    return CalibrationError::kTooManySensors;
  }
  if (!std::isfinite(input.distance) || !(input.distance > 0.0) || !std::isfinite(input.turns) ||
      input.turns == 0.0) {
    return CalibrationError::kBadInput;
  }

  // Directions, judged with the nominal sensor matrices.
  Directions dir;
  {
    double sx = 0.0, sy = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Matrix2d g_inv = nominal[static_cast<int>(i)].robot_velocity_from_counts();
      sx += (g_inv * input.push_x[i]).x();
      if (input.push_y) sy += (g_inv * (*input.push_y)[i]).y();
    }
    dir.push_x_reversed = sx < 0.0;
    dir.push_y_reversed = input.push_y && sy < 0.0;
    dir.spin_clockwise = input.turns < 0.0;
  }
  GuidedInput in = input;
  in.turns = std::abs(input.turns);
  // The spin's direction: the one that puts the sensors nearer their
  // nominal places (the other mirrors every position through the centre).
  const auto distance_to_nominal = [&](const Solution& sol) {
    double sum = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      sum += (sol.mounts[i].position - nominal[static_cast<int>(i)].position).squaredNorm();
    }
    return sum;
  };
  auto base = solve(nominal, in, dir, nullptr);
  Directions other = dir;
  other.spin_clockwise = !dir.spin_clockwise;
  const auto alternative = solve(nominal, in, other, nullptr);
  if (!base && !alternative) return CalibrationError::kBadInput;
  if (!base || (alternative && distance_to_nominal(*alternative) < distance_to_nominal(*base))) {
    base = alternative;
    dir = other;
  }

  GuidedCalibration out;
  out.isotropic_scale = !input.push_y.has_value();
  out.push_x_reversed = dir.push_x_reversed;
  out.push_y_reversed = dir.push_y_reversed;
  out.spin_clockwise = dir.spin_clockwise;
  out.push_misfit = base->misfit;
  out.calibrated = SensorArray(base->mounts);

  // 1-sigma from the procedural tolerances: re-solve with each source at +-1 sd.
  const double angle = 2.0 * std::numbers::pi * in.turns * (dir.spin_clockwise ? -1.0 : 1.0);
  const double push_x_sign = dir.push_x_reversed ? -1.0 : 1.0;
  const double push_y_sign = dir.push_y_reversed ? -1.0 : 1.0;
  const Eigen::VectorXd x0 = stacked(base->mounts);
  out.covariance = Eigen::MatrixXd::Zero(x0.size(), x0.size());
  const auto propagate = [&](const std::function<void(GuidedInput&, double)>& perturb,
                             double anisotropy_sd = 0.0) {
    GuidedInput plus = in, minus = in;
    perturb(plus, 1.0);
    perturb(minus, -1.0);
    const auto a = solve(nominal, plus, dir, &base->flipped, 1.0 + anisotropy_sd);
    const auto b = solve(nominal, minus, dir, &base->flipped, 1.0 - anisotropy_sd);
    if (!a || !b) return;
    Eigen::VectorXd delta = (stacked(a->mounts) - stacked(b->mounts)) / 2.0;
    for (std::size_t i = 0; i < n; ++i) {
      const auto yaw = static_cast<Eigen::Index>(kMountParameters * i + 2);
      delta(yaw) = wrap_angle(delta(yaw) * 2.0) / 2.0;
    }
    out.covariance += delta * delta.transpose();
  };
  const auto& mounts = base->mounts;
  const auto q = [&](std::size_t i) { return Eigen::Vector2d(in.spin[i] / angle); };
  propagate([&](GuidedInput& g, double s) {
    for (auto& c : g.push_x) c *= (in.distance + s * tolerances.distance_sd) / in.distance;
  });
  if (in.push_y) {
    propagate([&](GuidedInput& g, double s) {
      for (auto& c : *g.push_y) c *= (in.distance + s * tolerances.distance_sd) / in.distance;
    });
  }
  propagate([&](GuidedInput& g, double s) {
    const double a = std::abs(angle);
    for (auto& c : g.spin) c *= (a + s * tolerances.turn_sd) / a;
  });
  for (int axis = 0; axis < 2; ++axis) {
    propagate([&](GuidedInput& g, double s) {
      Eigen::Vector2d centre = Eigen::Vector2d::Zero();
      centre(axis) = s * tolerances.centre_sd;
      for (std::size_t i = 0; i < n; ++i) {
        g.spin[i] -= angle * mounts[i].counts_from_robot_velocity() * skew_unit() * centre;
      }
    });
  }
  propagate([&](GuidedInput& g, double s) {
    for (std::size_t i = 0; i < n; ++i)
      g.push_x[i] += push_x_sign * q(i) * s * tolerances.heading_sd;
  });
  if (!in.push_y) propagate([](GuidedInput&, double) {}, tolerances.anisotropy_sd);
  if (in.push_y) {
    propagate([&](GuidedInput& g, double s) {
      for (std::size_t i = 0; i < n; ++i) {
        (*g.push_y)[i] += push_y_sign * q(i) * s * tolerances.heading_sd;
      }
    });
  }

  Eigen::Vector2d mean_cal = Eigen::Vector2d::Zero(), mean_nom = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    const int ii = static_cast<int>(i);
    SensorCalibration s;
    s.nominal = nominal[ii];
    s.calibrated = mounts[i];
    s.estimated.fill(true);
    s.mirror_from_data = base->mirror_from_data[i];
    s.covariance = out.covariance.block<5, 5>(5 * ii, 5 * ii);
    out.sensors.push_back(s);
    mean_cal += mounts[i].position;
    mean_nom += nominal[ii].position;
  }
  out.centroid_shift = (mean_cal - mean_nom) / static_cast<double>(n);
  return out;
}

}  // namespace moa
