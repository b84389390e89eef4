// moa calibrate: where the sensors really sit (docs/formats/cli.md, docs/calibration.md).
//
//   --method kimlee|exact   mice.csv against the reference twist of wheels.csv
//   --method guided         count totals of a push along x (and y) and a spin
//
// Pairing of mice counts and reference (kimlee, exact): each wheels.csv row
// is the twist averaged over the interval from the previous row to its t,
// so the mice rows are integrated over exactly those intervals
// (moa::IntervalAccumulator: a row's counts spread in proportion to overlap,
// as the Synchroniser does); the first wheels row only opens the first
// interval, and intervals outside the span of mice.csv are not used.
// --min-interval merges consecutive wheels rows (duration-weighted mean
// twist) into longer intervals when the rows are shorter than the mice rows.
#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "calibrate_wizard.hpp"
#include "commands.hpp"
#include "moa/calibration/exact.hpp"
#include "moa/calibration/guided.hpp"
#include "moa/calibration/kimlee.hpp"
#include "moa/io/config.hpp"
#include "moa/io/error.hpp"
#include "moa/io/log.hpp"

namespace moa::cli {
namespace {

namespace fs = std::filesystem;

struct CalibrateArgs {
  std::string config;
  std::string method;
  std::string log;
  std::string out;
  std::string push_x;
  std::string push_y;
  std::string spin;
  std::optional<double> distance;
  std::optional<double> turns;
  double max_row_interval = 0.05;
  std::optional<double> min_interval;
  std::optional<int> measurements;
  double distance_sd = 0.002;
  double turn_sd = 0.0087;
  double centre_sd = 0.001;
  double heading_sd = 0.0044;
  bool json = false;
  bool quiet = false;
};

constexpr double kRadToDeg = 180.0 / std::numbers::pi;

// ------------------------------------------------------------ the report

// What every method reports per sensor, as printed and as JSON.
struct SensorReport {
  std::string name;
  SensorMount nominal;
  SensorMount calibrated;
  MountVector sigma = MountVector::Zero();
  std::array<bool, kMountParameters> estimated{};
  bool mirror_from_data = false;
  std::optional<double> residual_rms;      // m/s (kimlee, exact)
  std::optional<double> push_misfit;       // m (guided)
  std::optional<MountVector> eigenvalues;  // exact: observability
};

struct Report {
  std::string method;
  std::vector<std::string> lines;  // method-specific facts, printed before the table
  std::vector<SensorReport> sensors;
  std::vector<std::string> warnings;
  std::string json_extra;  // ", \"key\": value" pairs
};

std::string yes_no(bool b) { return b ? "yes" : "no"; }

void print_report(const Report& r, const std::string& out) {
  fmt::print("moa calibrate --method {}\n", r.method);
  for (const auto& line : r.lines) fmt::print("  {}\n", line);
  for (const auto& s : r.sensors) {
    fmt::print("\nsensor {}\n", s.name);
    fmt::print("  {:<14} {:>12} {:>12} {:>12}\n", "parameter", "nominal", "calibrated", "1-sigma");
    const MountVector a = mount_parameters(s.nominal);
    const MountVector b = mount_parameters(s.calibrated);
    const std::array<const char*, kMountParameters> labels{"position x m", "position y m",
                                                           "yaw deg", "scale x", "scale y"};
    for (int p = 0; p < kMountParameters; ++p) {
      const double unit = p == 2 ? kRadToDeg : 1.0;
      const int digits = p < 2 ? 5 : 4;
      const std::string sigma = s.estimated[static_cast<std::size_t>(p)]
                                    ? fmt::format("{:.{}f}", s.sigma(p) * unit, p < 2 ? 6 : 5)
                                    : std::string("kept");
      fmt::print("  {:<14} {:>12.{}f} {:>12.{}f} {:>12}\n", labels[static_cast<std::size_t>(p)],
                 a(p) * unit, digits, b(p) * unit, digits, sigma);
    }
    fmt::print("  {:<14} {:>12} {:>12} {:>12}\n", "mirrored", yes_no(s.nominal.mirrored),
               yes_no(s.calibrated.mirrored), s.mirror_from_data ? "from data" : "kept");
    if (s.residual_rms) {
      fmt::print("  {:<14} {:.3f} mm/s\n", "residual RMS", *s.residual_rms * 1e3);
    }
    if (s.push_misfit) fmt::print("  {:<14} {:.3f} mm\n", "push misfit", *s.push_misfit * 1e3);
    if (s.eigenvalues) {
      fmt::print("  {:<14} {:.3g}\n", "information", fmt::join(*s.eigenvalues, " "));
    }
  }
  fmt::print("\n");
  if (r.warnings.empty()) {
    fmt::print("warnings: none\n");
  } else {
    fmt::print("warnings:\n");
    for (const auto& w : r.warnings) fmt::print("  {}\n", w);
  }
  fmt::print("calibrated config written to {}\n", out);
}

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      out += fmt::format("\\u{:04x}", static_cast<int>(c));
    } else {
      out += c;
    }
  }
  return out + "\"";
}

std::string json_mount(const SensorMount& m) {
  return fmt::format(
      "{{\"position\": [{:.9g}, {:.9g}], \"yaw\": {:.9g}, \"scale\": [{:.9g}, {:.9g}], "
      "\"mirrored\": {}}}",
      m.position.x(), m.position.y(), m.yaw, m.scale.x(), m.scale.y(), m.mirrored);
}

void print_json(const Report& r, const std::string& out) {
  std::vector<std::string> sensors;
  for (const auto& s : r.sensors) {
    std::string e = fmt::format(
        "{{\"name\": {}, \"nominal\": {}, \"calibrated\": {}, \"sigma\": {{\"position\": [{:.9g}, "
        "{:.9g}], \"yaw\": {:.9g}, \"scale\": [{:.9g}, {:.9g}]}}, \"estimated\": {{\"position_x\": "
        "{}, \"position_y\": {}, \"yaw\": {}, \"scale_x\": {}, \"scale_y\": {}}}, "
        "\"mirror_from_data\": {}",
        json_string(s.name), json_mount(s.nominal), json_mount(s.calibrated), s.sigma(0),
        s.sigma(1), s.sigma(2), s.sigma(3), s.sigma(4), s.estimated[0], s.estimated[1],
        s.estimated[2], s.estimated[3], s.estimated[4], s.mirror_from_data);
    if (s.residual_rms) e += fmt::format(", \"residual_rms_m_s\": {:.9g}", *s.residual_rms);
    if (s.push_misfit) e += fmt::format(", \"push_misfit_m\": {:.9g}", *s.push_misfit);
    if (s.eigenvalues) {
      e += fmt::format(", \"information_eigenvalues\": [{:.6g}]", fmt::join(*s.eigenvalues, ", "));
    }
    sensors.push_back(e + "}");
  }
  std::vector<std::string> warnings;
  for (const auto& w : r.warnings) warnings.push_back(json_string(w));
  fmt::print("{{\"method\": {}, \"out\": {}{}, \"sensors\": [{}], \"warnings\": [{}]}}\n",
             json_string(r.method), json_string(out), r.json_extra, fmt::join(sensors, ", "),
             fmt::join(warnings, ", "));
}

std::string list_kept(const std::array<bool, kMountParameters>& estimated) {
  std::vector<std::string> kept;
  for (int p = 0; p < kMountParameters; ++p) {
    if (!estimated[static_cast<std::size_t>(p)])
      kept.emplace_back(describe(static_cast<MountParameter>(p)));
  }
  return fmt::format("{}", fmt::join(kept, ", "));
}

// Warnings any method gives about the result itself.
void plausibility_warnings(Report& r) {
  for (const auto& s : r.sensors) {
    const double moved = (s.calibrated.position - s.nominal.position).norm();
    if (moved > 0.02) {
      r.warnings.push_back(
          fmt::format("{}: calibrated position is {:.1f} mm from nominal: check the nominal config",
                      s.name, moved * 1e3));
    }
    const double scale = (s.calibrated.scale - s.nominal.scale).cwiseAbs().maxCoeff();
    if (scale > 0.2) {
      r.warnings.push_back(
          fmt::format("{}: scale differs from nominal by {:.0f} %: is the cpi in the config right?",
                      s.name, scale * 100.0));
    }
    if (s.calibrated.mirrored != s.nominal.mirrored) {
      r.warnings.push_back(fmt::format(
          "{}: mirrored in the data but not in the nominal config (calibrated config says "
          "mirrored: {})",
          s.name, s.calibrated.mirrored ? "true" : "false"));
    }
  }
}

// ------------------------------------------------------------ reading

fs::path log_dir_of(const fs::path& log) { return fs::is_directory(log) ? log : log.parent_path(); }

struct ReferenceData {
  std::vector<CalibrationSample> samples;
  fs::path wheels;
  std::size_t wheel_rows = 0;
  std::size_t repeated_rows = 0;
  std::size_t intervals = 0;  // intervals defined by the wheels rows (after merging)
  std::size_t covered = 0;    // of those, within the time span of mice.csv
  std::size_t unusable = 0;   // of those, with a lift or overflow flag
  int measurements = 0;       // groups the usable intervals were summed into (0: none)
};

// Shortest reference interval. Counts summed over longer intervals carry
// the same information about a model linear in the twist but less of the
// rows' quantisation (a sum of carried roundings is exact to one count):
// exact merges wheels rows into intervals of at least 50 ms by default.
double min_interval_of(const CalibrateArgs& args) {
  if (args.min_interval) return *args.min_interval;
  return args.method == "exact" ? 0.05 : 0.0;
}

// Kim & Lee's M: the paper's ten measurements unless told otherwise.
int measurements_of(const CalibrateArgs& args) {
  if (args.measurements) return *args.measurements;
  return args.method == "kimlee" ? 10 : 0;
}

ReferenceData read_reference(const CalibrateArgs& args, const io::RobotConfig& config) {
  ReferenceData ref;
  ref.wheels = log_dir_of(args.log) / "wheels.csv";
  if (!fs::exists(ref.wheels)) {
    throw io::Error(fmt::format(
        "{}: not found: --method {} needs the reference twists (t,vx,vy,omega) of the robot",
        ref.wheels.string(), args.method));
  }
  const auto rows = io::read_all<io::WheelRow>(ref.wheels);
  ref.wheel_rows = rows.size();
  if (rows.size() < 2) {
    throw io::Error(fmt::format(
        "{}: {} data rows: needs at least two (the first only opens the first interval)",
        ref.wheels.string(), rows.size()));
  }

  // Interval ends and their mean twists; repeated times give empty
  // intervals and are dropped (counted in a warning).
  std::vector<double> times{rows.front().t};
  std::vector<Twist2> twists;
  Eigen::Vector3d acc = Eigen::Vector3d::Zero();
  double acc_dt = 0.0;
  double last = rows.front().t;
  const double min_interval = min_interval_of(args);
  for (std::size_t k = 1; k < rows.size(); ++k) {
    const double dt = rows[k].t - last;
    if (!(dt > 0.0)) {
      ++ref.repeated_rows;
      continue;
    }
    acc += rows[k].twist.vector() * dt;
    acc_dt += dt;
    last = rows[k].t;
    // Rounding of the times must not make a 50 ms group of 10 ms rows wait for a sixth.
    if (acc_dt >= min_interval * (1.0 - 1e-9)) {
      times.push_back(last);
      twists.push_back(Twist2::from_vector(acc / acc_dt));
      acc.setZero();
      acc_dt = 0.0;
    }
  }
  ref.intervals = twists.size();

  io::MiceReader reader(args.log, config);
  const double t0 = reader.start_time();
  IntervalAccumulator intervals(config.array.size(), t0, times, args.max_row_interval);
  std::size_t n_rows = 0;
  while (const auto row = reader.next()) {
    ++n_rows;
    if (const auto error = intervals.add(*row)) {
      throw io::Error(
          fmt::format("{}: row {} (t = {} s): {}", args.log, n_rows, row->t, describe(*error)));
    }
  }
  std::vector<CalibrationSample> samples;
  for (const auto& iv : intervals.covered()) {
    const CalibrationSample s{iv.sample, twists[static_cast<std::size_t>(iv.index)]};
    ++ref.covered;
    if (usable_sample(s, config.array.size())) {
      samples.push_back(s);
    } else {
      ++ref.unusable;
    }
  }
  ref.measurements = measurements_of(args);
  ref.samples = merge_samples(samples, ref.measurements);
  return ref;
}

struct Totals {
  std::vector<Eigen::Vector2d> counts;
  std::vector<std::uint8_t> flags;
};

Totals count_totals(const std::string& dir, const io::RobotConfig& config) {
  io::MiceReader reader(dir, config);
  Totals t;
  t.counts.assign(static_cast<std::size_t>(config.array.size()), Eigen::Vector2d::Zero());
  t.flags.assign(static_cast<std::size_t>(config.array.size()), 0);
  while (const auto row = reader.next()) {
    const auto i = static_cast<std::size_t>(row->sensor);
    t.counts[i] += row->counts;
    t.flags[i] |= row->flags;
  }
  return t;
}

// ------------------------------------------------------------ methods

void common_sample_lines(Report& r, const ReferenceData& ref, const CalibrateArgs& args) {
  r.lines.push_back(fmt::format(
      "reference: {} ({} rows, {} intervals{}); {} within mice.csv, {} usable{}",
      ref.wheels.string(), ref.wheel_rows, ref.intervals,
      min_interval_of(args) > 0.0 ? fmt::format(" of >= {} s", min_interval_of(args))
                                  : std::string(),
      ref.covered, ref.covered - ref.unusable,
      ref.measurements > 0 &&
              static_cast<std::size_t>(ref.measurements) < ref.covered - ref.unusable
          ? fmt::format(", summed into {} measurements of equal duration", ref.samples.size())
          : std::string()));
  if (ref.unusable > 0) {
    r.warnings.push_back(fmt::format(
        "{} intervals skipped: a sensor reported lift or counter overflow", ref.unusable));
  }
  if (ref.repeated_rows > 0) {
    r.warnings.push_back(fmt::format("{}: {} rows repeat the previous time and were not used",
                                     ref.wheels.string(), ref.repeated_rows));
  }
}

std::size_t minimum_samples(const std::string& method) { return method == "exact" ? 3 : 1; }

void check_sample_count(const ReferenceData& ref, const CalibrateArgs& args) {
  const std::size_t need = minimum_samples(args.method);
  if (ref.samples.size() < need) {
    throw io::Error(fmt::format(
        "{}: {} usable reference interval(s) within the time span of mice.csv; --method {} needs "
        "at least {}",
        ref.wheels.string(), ref.samples.size(), args.method, need));
  }
}

[[noreturn]] void fail(const CalibrateArgs& args, CalibrationError error) {
  throw io::Error(fmt::format("{}: --method {}: {}", args.log.empty() ? args.config : args.log,
                              args.method, describe(error)));
}

Report run_kimlee(const CalibrateArgs& args, const io::RobotConfig& config, SensorArray& out) {
  const ReferenceData ref = read_reference(args, config);
  check_sample_count(ref, args);
  const auto result = calibrate_kimlee(config.array, ref.samples);
  if (const auto* e = std::get_if<CalibrationError>(&result)) fail(args, *e);
  const auto& cal = std::get<KimLeeCalibration>(result);
  Report r;
  r.method = "kimlee";
  common_sample_lines(r, ref, args);
  const int n = config.array.size();
  r.lines.push_back(fmt::format(
      "Kim & Lee eqs. (44)-(47): S is {} x {}, rank {} of {} (singular values above {:.3g})",
      cal.measurements + 2, 2 * n, cal.rank, 2 * n, cal.threshold));
  r.lines.push_back(
      fmt::format("singular values of S: {:.6g}", fmt::join(cal.singular_values, " ")));
  r.lines.push_back(
      fmt::format("threshold = 3 x {:.3g} m/s (velocity noise) x (sqrt({}) + sqrt({}))",
                  cal.velocity_noise, cal.measurements + 2, 2 * n));
  r.lines.push_back("positions only, as in the paper: yaw, scale and mirroring stay nominal");
  for (int i = 0; i < n; ++i) {
    SensorReport s;
    s.name = config.names[static_cast<std::size_t>(i)];
    s.nominal = config.array[i];
    s.calibrated = cal.calibrated[i];
    s.sigma(0) = std::sqrt(std::max(cal.covariance(2 * i, 2 * i), 0.0));
    s.sigma(1) = std::sqrt(std::max(cal.covariance(2 * i + 1, 2 * i + 1), 0.0));
    s.estimated = {true, true, false, false, false};
    s.residual_rms = cal.residual_rms[static_cast<std::size_t>(i)];
    r.sensors.push_back(s);
  }
  if (cal.rank_deficient()) {
    r.warnings.push_back(fmt::format(
        "S is rank deficient ({} < {}): the motion determines only {} combinations of the {} "
        "position corrections; this is the minimum-norm correction (Kim & Lee's S has rank 3 for "
        "any motion to first order: row 3 of every S_k is omega (p - 2 p_nominal)); the 1-sigma "
        "covers the determined combinations only, along the other {} directions the data say "
        "nothing; use --method exact for the true positions",
        cal.rank, 2 * n, cal.rank, 2 * n, 2 * n - cal.rank));
  }
  if (cal.too_few_measurements()) {
    r.warnings.push_back(fmt::format("M = {} measurements < 2N - 2 = {} (Kim & Lee eq. (49))",
                                     cal.measurements, 2 * n - 2));
  }
  r.json_extra = fmt::format(
      ", \"samples\": {}, \"rank\": {}, \"unknowns\": {}, \"threshold\": {:.9g}, "
      "\"velocity_noise_m_s\": {:.9g}, \"singular_values\": [{:.9g}]",
      cal.measurements, cal.rank, 2 * n, cal.threshold, cal.velocity_noise,
      fmt::join(cal.singular_values, ", "));
  out = cal.calibrated;
  return r;
}

Report run_exact(const CalibrateArgs& args, const io::RobotConfig& config, SensorArray& out) {
  const ReferenceData ref = read_reference(args, config);
  check_sample_count(ref, args);
  const auto result = calibrate_exact(config.array, ref.samples);
  if (const auto* e = std::get_if<CalibrationError>(&result)) fail(args, *e);
  const auto& cal = std::get<ExactCalibration>(result);
  Report r;
  r.method = "exact";
  common_sample_lines(r, ref, args);
  const Eigen::Vector3d ref_sd = cal.noise.reference_covariance.diagonal().cwiseSqrt();
  r.lines.push_back(fmt::format(
      "reference noise (estimated, 1-sigma per interval): vx {:.4g} m/s, vy {:.4g} m/s, omega "
      "{:.4g} rad/s",
      ref_sd(0), ref_sd(1), ref_sd(2)));
  const auto& var = cal.noise.counts_variance;
  if (std::all_of(var.begin(), var.end(), [&](double v) { return v == var.front(); })) {
    r.lines.push_back(
        fmt::format("count noise (estimated, every sensor): {:.3g} counts per interval and axis",
                    std::sqrt(var.front())));
  } else {
    std::vector<std::string> count_sd;
    for (std::size_t i = 0; i < var.size(); ++i) {
      count_sd.push_back(fmt::format("{} {:.3g}", config.names[i], std::sqrt(var[i])));
    }
    r.lines.push_back(
        fmt::format("count noise (counts per interval and axis): {}", fmt::join(count_sd, ", ")));
  }
  r.lines.push_back(
      fmt::format("{} samples used, {} rejected as outliers, {} unusable (lift/overflow); "
                  "{} iterations",
                  cal.samples_used, cal.samples_rejected, cal.samples_unusable, cal.iterations));
  r.lines.push_back(
      "information: eigenvalues of the Fisher information in units of a generous mounting "
      "error (10 mm, 10 mm, 0.1 rad, 5 %, 5 %); below 1 means not excited");
  std::vector<std::string> unexcited;
  for (std::size_t i = 0; i < cal.sensors.size(); ++i) {
    const SensorCalibration& c = cal.sensors[i];
    SensorReport s;
    s.name = config.names[i];
    s.nominal = c.nominal;
    s.calibrated = c.calibrated;
    s.sigma = c.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
    s.estimated = c.estimated;
    s.mirror_from_data = c.mirror_from_data;
    s.residual_rms = c.residual_rms;
    s.eigenvalues = c.scaled_eigenvalues;
    r.sensors.push_back(s);
    const std::string kept = list_kept(c.estimated);
    if (!kept.empty()) {
      unexcited.push_back(fmt::format("{}: {}", s.name, kept));
      r.warnings.push_back(fmt::format(
          "{}: {} not excited by the motion: kept at nominal{}", s.name, kept,
          c.estimated[2] && c.estimated[3] && c.estimated[4] ? ""
                                                             : "; mirroring kept from the config"));
    }
  }
  r.lines.push_back(unexcited.empty()
                        ? std::string("observability: every parameter of every sensor excited")
                        : fmt::format("observability: kept at nominal (not excited): {}",
                                      fmt::join(unexcited, "; ")));
  if (cal.samples_rejected > 0) {
    r.warnings.push_back(fmt::format(
        "{} samples rejected as outliers (residual beyond the chi-square 1e-6 quantile): wheel "
        "slip or a lifted sensor?",
        cal.samples_rejected));
  }
  if (cal.model_misfit) {
    r.warnings.push_back(
        "more than 5 % of the samples disagree with the model beyond the noise: check the time "
        "alignment of wheels.csv and mice.csv, wheel slip, sensors lifting");
  }
  if (cal.samples_unusable > 0) {
    r.warnings.push_back(fmt::format(
        "{} samples skipped: a sensor reported lift or counter overflow", cal.samples_unusable));
  }
  if (!cal.converged) r.warnings.push_back("the optimiser did not converge: the result is rough");
  if (ref.samples.size() < 30) {
    r.warnings.push_back(fmt::format(
        "only {} samples: the noise levels (and so the 1-sigma) are rough", ref.samples.size()));
  }
  r.json_extra = fmt::format(
      ", \"samples\": {}, \"samples_rejected\": {}, \"samples_unusable\": {}, "
      "\"reference_noise_sd\": [{:.9g}, {:.9g}, {:.9g}], \"converged\": {}",
      cal.samples_used, cal.samples_rejected, cal.samples_unusable, ref_sd(0), ref_sd(1), ref_sd(2),
      cal.converged);
  out = cal.calibrated;
  return r;
}

Report run_guided(const CalibrateArgs& args, const io::RobotConfig& config, SensorArray& out) {
  Report r;
  r.method = "guided";
  const auto read = [&](const std::string& dir, const char* what, bool all_must_count) {
    const Totals t = count_totals(dir, config);
    for (std::size_t i = 0; i < t.counts.size(); ++i) {
      if (all_must_count && t.counts[i].isZero()) {
        throw io::Error(fmt::format(
            "{}: sensor '{}' counted nothing during the {}: lifted, disconnected or not in the "
            "recording?",
            dir, config.names[i], what));
      }
      if ((t.flags[i] & (kFlagLift | kFlagOverflow)) != 0) {
        r.warnings.push_back(fmt::format(
            "{}: sensor '{}' reported lift or overflow during the {}: its totals may be short", dir,
            config.names[i], what));
      }
    }
    return t.counts;
  };
  GuidedInput in;
  in.push_x = read(args.push_x, "push along x", true);
  if (!args.push_y.empty()) in.push_y = read(args.push_y, "push along y", true);
  in.spin = read(args.spin, "spin", false);
  in.distance = *args.distance;
  in.turns = *args.turns;
  GuidedTolerances tol;
  tol.distance_sd = args.distance_sd;
  tol.turn_sd = args.turn_sd;
  tol.centre_sd = args.centre_sd;
  tol.heading_sd = args.heading_sd;
  const auto result = calibrate_guided(config.array, in, tol);
  if (const auto* e = std::get_if<CalibrationError>(&result)) fail(args, *e);
  const auto& cal = std::get<GuidedCalibration>(result);

  r.lines.push_back(fmt::format("push along x: {}, {} m{}", args.push_x, in.distance,
                                cal.push_x_reversed ? " (done backwards: detected)" : ""));
  if (in.push_y) {
    r.lines.push_back(fmt::format("push along y: {}, {} m{}", args.push_y, in.distance,
                                  cal.push_y_reversed ? " (done backwards: detected)" : ""));
  }
  r.lines.push_back(fmt::format("spin: {}, {} turns {}", args.spin, std::abs(in.turns),
                                cal.spin_clockwise ? "clockwise" : "counter-clockwise"));
  r.lines.push_back(fmt::format(
      "1-sigma from the procedure's tolerances: distance {} m, spin angle {} rad, spin centre {} m "
      "per axis, heading change during a push {} rad",
      tol.distance_sd, tol.turn_sd, tol.centre_sd, tol.heading_sd));
  r.lines.push_back("positions are relative to the point the robot was spun about");
  for (std::size_t i = 0; i < cal.sensors.size(); ++i) {
    const SensorCalibration& c = cal.sensors[i];
    SensorReport s;
    s.name = config.names[i];
    s.nominal = c.nominal;
    s.calibrated = c.calibrated;
    s.sigma = c.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
    s.estimated = c.estimated;
    s.mirror_from_data = c.mirror_from_data;
    s.push_misfit = cal.push_misfit[i];
    r.sensors.push_back(s);
  }
  if (cal.isotropic_scale) {
    r.warnings.push_back(
        "no --push-y: each sensor's scale taken equal on both axes (1-sigma includes a 2 % "
        "difference) and mirroring judged by which puts the sensor nearer its nominal place");
  }
  if ((in.turns < 0.0) != cal.spin_clockwise) {
    r.warnings.push_back(
        fmt::format("--turns {} says {}, the counts say {}: used as the counts say", in.turns,
                    in.turns < 0.0 ? "clockwise" : "counter-clockwise",
                    cal.spin_clockwise ? "clockwise" : "counter-clockwise"));
  }
  if (cal.push_x_reversed) r.warnings.push_back("the push along x went towards -x: used as such");
  if (cal.push_y_reversed) r.warnings.push_back("the push along y went towards -y: used as such");
  if (cal.centroid_shift.norm() > 0.003) {
    r.warnings.push_back(fmt::format(
        "the sensors' mean position moved by ({:.1f}, {:.1f}) mm from nominal: if the spin was not "
        "about the robot's centre, every position is shifted by that offset",
        cal.centroid_shift.x() * 1e3, cal.centroid_shift.y() * 1e3));
  }
  for (std::size_t i = 0; i < cal.push_misfit.size(); ++i) {
    if (cal.push_misfit[i] > 0.005 * in.distance) {
      r.warnings.push_back(
          fmt::format("{}: the two pushes disagree with one sensor frame by {:.1f} mm: were they "
                      "perpendicular and without turning?",
                      config.names[i], cal.push_misfit[i] * 1e3));
    }
  }
  r.json_extra = fmt::format(
      ", \"isotropic_scale\": {}, \"push_x_reversed\": {}, \"push_y_reversed\": {}, "
      "\"spin_clockwise\": {}, \"centroid_shift\": [{:.9g}, {:.9g}]",
      cal.isotropic_scale, cal.push_x_reversed, cal.push_y_reversed, cal.spin_clockwise,
      cal.centroid_shift.x(), cal.centroid_shift.y());
  out = cal.calibrated;
  return r;
}

// ------------------------------------------------------------ the command

void check_flags(const CalibrateArgs& a) {
  const auto need = [&](bool present, const char* flag) {
    if (!present) throw io::Error(fmt::format("--method {} needs {}", a.method, flag));
  };
  const auto refuse = [&](bool present, const char* flag, const char* why) {
    if (present)
      throw io::Error(fmt::format("{} is not used by --method {}: {}", flag, a.method, why));
  };
  if (a.method == "guided") {
    refuse(!a.log.empty(), "--log",
           "guided calibration takes --push-x, --push-y and --spin recordings");
    need(!a.push_x.empty(), "--push-x DIR (a push of --distance metres along the robot's x axis)");
    need(!a.spin.empty(), "--spin DIR (--turns whole turns about the robot's centre)");
    need(a.distance.has_value(), "--distance METRES (the length of each push)");
    need(a.turns.has_value(), "--turns K (whole turns of the spin)");
    if (!(std::isfinite(*a.distance) && *a.distance > 0.0)) {
      throw io::Error(
          fmt::format("--distance {}: must be a positive number of metres", *a.distance));
    }
    if (!std::isfinite(*a.turns) || *a.turns == 0.0) {
      throw io::Error(fmt::format("--turns {}: must be a non-zero number of turns", *a.turns));
    }
    refuse(a.measurements.has_value(), "--measurements", "it has no reference intervals");
    refuse(a.min_interval.has_value(), "--min-interval", "it has no reference intervals");
  } else {
    need(!a.log.empty(), "--log DIR (a log with mice.csv and wheels.csv)");
    const char* why = "it belongs to --method guided";
    refuse(!a.push_x.empty(), "--push-x", why);
    refuse(!a.push_y.empty(), "--push-y", why);
    refuse(!a.spin.empty(), "--spin", why);
    refuse(a.distance.has_value(), "--distance", why);
    refuse(a.turns.has_value(), "--turns", why);
  }
}

int run_calibrate(const CalibrateArgs& args) {
  check_flags(args);
  const io::RobotConfig config = io::read_config(args.config);
  SensorArray calibrated;
  Report report;
  if (args.method == "kimlee") {
    report = run_kimlee(args, config, calibrated);
  } else if (args.method == "exact") {
    report = run_exact(args, config, calibrated);
  } else {
    report = run_guided(args, config, calibrated);
  }
  plausibility_warnings(report);
  io::RobotConfig out_config = config;
  out_config.array = calibrated;
  io::write_config(out_config, args.out);
  if (args.json) {
    print_json(report, args.out);
  } else if (!args.quiet) {
    print_report(report, args.out);
  }
  return 0;
}

}  // namespace

void add_calibrate(CLI::App& app, Action& action) {
  auto args = std::make_shared<CalibrateArgs>();
  auto* cmd = app.add_subcommand(
      "calibrate",
      "Sensor positions, yaw, scale and mirroring from a log with reference twists "
      "(kimlee, exact) or from a push and a spin (guided); writes a config v1");
  cmd->add_option("--config", args->config, "Nominal robot config v1 (YAML)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--method", args->method,
                  "kimlee: Kim & Lee Section IV (positions only); exact: all extrinsics against "
                  "wheels.csv; guided: pushes and a spin, no reference")
      ->check(CLI::IsMember({"kimlee", "exact", "guided"}));
  cmd->add_option("--log", args->log, "Log directory with mice.csv and wheels.csv (kimlee, exact)")
      ->check(CLI::ExistingPath);
  cmd->add_option("--out", args->out, "Calibrated config v1 (written whole or not at all)")
      ->required();
  cmd->add_option("--push-x", args->push_x, "guided: log of a push along the robot's x axis")
      ->check(CLI::ExistingPath);
  cmd->add_option("--push-y", args->push_y, "guided: log of a push along the robot's y axis")
      ->check(CLI::ExistingPath);
  cmd->add_option("--spin", args->spin, "guided: log of whole turns about the robot's centre")
      ->check(CLI::ExistingPath);
  cmd->add_option("--distance", args->distance, "guided: length of each push, m");
  cmd->add_option("--turns", args->turns, "guided: number of whole turns of the spin");
  cmd->add_option("--max-row-interval", args->max_row_interval,
                  "Longest interval one mice.csv row may cover, s")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--min-interval", args->min_interval,
                  "kimlee, exact: merge consecutive wheels.csv rows into intervals of at least "
                  "this many seconds (default: 0.05 for exact, 0 for kimlee)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--measurements", args->measurements,
                  "kimlee, exact: sum the intervals into this many measurements of equal "
                  "duration (default: 10 for kimlee, the paper's M; every interval for exact); 0: "
                  "every interval")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--distance-sd", args->distance_sd, "guided: 1-sigma of the push distance, m")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--turn-sd", args->turn_sd, "guided: 1-sigma of the spin's total angle, rad")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--centre-sd", args->centre_sd, "guided: 1-sigma of the spin centre per axis, m")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--heading-sd", args->heading_sd,
                  "guided: 1-sigma of the robot's turning during a push, rad")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_flag("--json", args->json, "Print the report as one JSON object (SI units)");
  cmd->add_flag("--quiet", args->quiet, "Print nothing on success");
  // --guided [--live]: the live, step-by-step guided calibration (calibrate_wizard.cpp).
  auto wizard = std::make_shared<WizardArgs>();
  add_wizard_flags(cmd, *wizard);
  cmd->callback([&action, args, wizard] {
    if (wizard->live) {
      wizard->config = args->config;
      wizard->out = args->out;
      wizard->distance = args->distance;
      wizard->turns = args->turns;
      wizard->tolerances.distance_sd = args->distance_sd;
      wizard->tolerances.turn_sd = args->turn_sd;
      wizard->tolerances.centre_sd = args->centre_sd;
      wizard->tolerances.heading_sd = args->heading_sd;
      action = [wizard] { return run_wizard(*wizard); };
      return;
    }
    if (wizard->guided && args->method.empty()) args->method = "guided";
    action = [args, wizard] {
      if (args->method.empty()) throw io::Error("--method is required (or --guided)");
      refuse_live_flags(*wizard);
      return run_calibrate(*args);
    };
  });
}

}  // namespace moa::cli
