#include "moa/runs/run_summary.hpp"

#include <fmt/core.h>

#include <cmath>

namespace moa::io {

void RunSummary::add(const OdometryStep& step, int sensors) {
  ++epochs;
  ++epochs_by_source[static_cast<std::size_t>(step.estimate.source)];
  for (int i = 0; i < sensors && i < kMaxSensors; ++i) {
    ++sensor_epochs[static_cast<std::size_t>(step.estimate.excluded[static_cast<std::size_t>(i)])];
  }
  const SourceTests& tests = step.estimate.tests;
  if (!std::isnan(tests.gyro) || tests.gyro_fused || tests.gyro_saturated) ++gyro_epochs;
  if (tests.gyro_fused) ++heading_from_gyro;
  if (step.gyro != nullptr) {
    gyro = GyroCalibration::of(*step.gyro);
  }
}

void RunSummary::add(const OdometryRow& row, int sensors) {
  ++epochs;
  if (row.source) ++epochs_by_source[static_cast<std::size_t>(*row.source)];
  if (row.listed == 0) return;  // no selection columns
  for (int i = 0; i < sensors && i < kMaxSensors; ++i) {
    ++sensor_epochs[static_cast<std::size_t>(row.excluded[static_cast<std::size_t>(i)])];
  }
}

bool RunSummary::usable() const {
  const auto held = static_cast<double>(epochs_by_source[static_cast<std::size_t>(Source::kHold)]);
  return epochs > 0 && held <= kMaxHeldFraction * static_cast<double>(epochs);
}

std::string RunSummary::verdict() const {
  const std::size_t held = epochs_by_source[static_cast<std::size_t>(Source::kHold)];
  if (epochs == 0) return "not usable: no epoch was written";
  const double percent = 100.0 * static_cast<double>(held) / static_cast<double>(epochs);
  if (!usable()) {
    return fmt::format(
        "not usable: {} of {} epochs ({:.1f} %) held the last twist (no sensor and no wheels "
        "measured the motion; at most {:g} % may)",
        held, epochs, percent, 100.0 * kMaxHeldFraction);
  }
  return fmt::format("usable: {} of {} epochs held the last twist (at most {:g} % may)", held,
                     epochs, 100.0 * kMaxHeldFraction);
}

std::string RunSummary::text() const {
  std::string out = fmt::format("epochs: {}", epochs);
  for (std::size_t s = 0; s < kSourceCount; ++s) {
    out += fmt::format("{}{} {}", s == 0 ? " (" : ", ", epochs_by_source[s],
                       to_name(static_cast<Source>(s)));
  }
  out += ")\nsensor-epochs:";
  for (std::size_t e = 0; e < kExclusionCount; ++e) {
    if (sensor_epochs[e] == 0 && e != 0) continue;
    out += fmt::format("{}{} {}", e == 0 ? " " : ", ", sensor_epochs[e],
                       to_name(static_cast<Exclusion>(e)));
  }
  out += "\n";
  if (fixes.applied + fixes.rejected + fixes.too_old + fixes.invalid > 0) {
    out += fmt::format(
        "camera fixes: {} applied, {} rejected as outliers, {} older than the filter's history, "
        "{} invalid\n",
        fixes.applied, fixes.rejected, fixes.too_old, fixes.invalid);
  }
  if (pose_lines > 0) {
    out += fmt::format("pose stream: {} lines, {} dropped (reader absent, slow or gone)\n",
                       pose_lines, pose_lines_dropped);
  }
  out += gyro_line();
  out += verdict() + "\n";
  return out;
}

std::string RunSummary::gyro_line() const {
  if (gyro_epochs == 0) return {};
  std::string out = "gyro: ";
  if (gyro) {
    out += fmt::format(
        "bias {:.5f} rad/s (sd {:.2g}), scale {:.4f} (sd {:.2g}), latency {:.1f} ms (sd {:.2g}), ",
        gyro->bias, gyro->bias_sd, gyro->scale, gyro->scale_sd, 1e3 * gyro->latency,
        1e3 * gyro->latency_sd);
  }
  const double percent =
      epochs > 0 ? 100.0 * static_cast<double>(heading_from_gyro) / static_cast<double>(epochs)
                 : 0.0;
  out += fmt::format("heading from the gyro in {} of {} epochs ({:.1f} %)\n", heading_from_gyro,
                     epochs, percent);
  if (gyro && gyro->bias_resets > 0) {
    out += fmt::format("gyro: its bias stepped {} time{} (learnt afresh each time)\n",
                       gyro->bias_resets, gyro->bias_resets == 1 ? "" : "s");
  }
  // More than kLatencySds of its sd from the config's: a false alarm at
  // about 0.3 % of runs while the config is right (a normal's two tails).
  if (gyro && std::abs(gyro->latency - gyro->configured_latency) > kLatencySds * gyro->latency_sd) {
    out += fmt::format(
        "gyro: its rows' latency is {:.1f} ms (sd {:.2g}), the config says {:.1f} ms: set "
        "imu.latency: {:.4f}\n",
        1e3 * gyro->latency, 1e3 * gyro->latency_sd, 1e3 * gyro->configured_latency, gyro->latency);
  }
  return out;
}

}  // namespace moa::io
