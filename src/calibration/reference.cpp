#include "moa/calibration/reference.hpp"

#include <fmt/core.h>

#include <Eigen/Core>

namespace moa {

ReferenceIntervals reference_intervals(std::span<const double> t, std::span<const Twist2> twist,
                                       double min_interval) {
  ReferenceIntervals out;
  if (t.empty()) return out;
  out.times.push_back(t.front());
  Eigen::Vector3d acc = Eigen::Vector3d::Zero();
  double acc_dt = 0.0;
  double last = t.front();
  for (std::size_t k = 1; k < t.size(); ++k) {
    const double dt = t[k] - last;
    if (!(dt > 0.0)) {
      ++out.repeated_rows;
      continue;
    }
    acc += twist[k].vector() * dt;
    acc_dt += dt;
    last = t[k];
    // Rounding of the times must not make a 50 ms group of 10 ms rows wait for a sixth.
    if (acc_dt >= min_interval * (1.0 - 1e-9)) {
      out.times.push_back(last);
      out.twists.push_back(Twist2::from_vector(acc / acc_dt));
      acc.setZero();
      acc_dt = 0.0;
    }
  }
  return out;
}

std::vector<std::string> plausibility_warnings(const std::string& name, const SensorMount& nominal,
                                               const SensorMount& calibrated) {
  std::vector<std::string> warnings;
  const double moved = (calibrated.position - nominal.position).norm();
  if (moved > 0.02) {
    warnings.push_back(
        fmt::format("{}: calibrated position is {:.1f} mm from nominal: check the nominal config",
                    name, moved * 1e3));
  }
  const double scale = (calibrated.scale - nominal.scale).cwiseAbs().maxCoeff();
  if (scale > 0.2) {
    warnings.push_back(
        fmt::format("{}: scale differs from nominal by {:.0f} %: is the cpi in the config right?",
                    name, scale * 100.0));
  }
  if (calibrated.mirrored != nominal.mirrored) {
    warnings.push_back(fmt::format(
        "{}: mirrored in the data but not in the nominal config (calibrated config says "
        "mirrored: {})",
        name, calibrated.mirrored ? "true" : "false"));
  }
  return warnings;
}

}  // namespace moa
