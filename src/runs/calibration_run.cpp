#include "moa/runs/calibration_run.hpp"

#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <iterator>
#include <numbers>
#include <optional>
#include <utility>
#include <vector>

#include "moa/calibration/guided_session.hpp"
#include "moa/calibration/reference.hpp"
#include "moa/core/estimate.hpp"
#include "moa/core/odometry.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/json.hpp"
#include "moa/formats/log.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa/runs/option_error.hpp"

namespace moa::io {
namespace {

namespace fs = std::filesystem;

std::string yes_no(bool b) { return b ? "yes" : "no"; }

std::string list_kept(const std::array<bool, kMountParameters>& estimated) {
  std::vector<std::string> kept;
  for (int p = 0; p < kMountParameters; ++p) {
    if (!estimated[static_cast<std::size_t>(p)])
      kept.emplace_back(describe(static_cast<MountParameter>(p)));
  }
  return fmt::format("{}", fmt::join(kept, ", "));
}

// ------------------------------------------------------------ reading

// A row whose counts imply a speed far beyond what its sensor can track is
// a corrupt value (2e9 counts), refused as `moa odometry` refuses it
// (core/sensor.hpp: impossible_speed, counts_impossible). The row's interval
// is taken as at least max_row_interval (odometry: one epoch, shorter), so
// nothing odometry accepts is refused here.
class CountsCheck {
 public:
  CountsCheck(const RobotConfig& config, double t0, double max_row_interval)
      : max_row_interval_(max_row_interval),
        last_(static_cast<std::size_t>(config.array.size()), t0) {
    for (int i = 0; i < config.array.size(); ++i) {
      to_velocity_.push_back(config.array[i].robot_velocity_from_counts());
      limit_.push_back(impossible_speed(config.array[i]));
    }
  }
  void check(const SensorRow& row, const MiceReader& reader) {
    const auto i = static_cast<std::size_t>(row.sensor);
    const double dt = std::max(row.t - last_[i], max_row_interval_);  // s
    last_[i] = std::max(last_[i], row.t);
    if (counts_impossible(to_velocity_[i], row.counts, limit_[i], dt)) {
      throw Error(fmt::format("{}:{}: row at t = {} s: {}", reader.file(), reader.line(), row.t,
                              describe(OdometryError::kImpossibleCounts)));
    }
  }

 private:
  double max_row_interval_;
  std::vector<double> last_;                  // s, per sensor
  std::vector<Eigen::Matrix2d> to_velocity_;  // counts -> m of the sensor point
  std::vector<double> limit_;                 // m/s
};

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
double min_interval_of(CalibrationMethod method, const CalibrationOptions& options) {
  if (options.min_interval) return *options.min_interval;
  return method == CalibrationMethod::kExact ? 0.05 : 0.0;
}

// Kim & Lee's M: the paper's ten measurements unless told otherwise.
int measurements_of(CalibrationMethod method, const CalibrationOptions& options) {
  if (options.measurements) return *options.measurements;
  return method == CalibrationMethod::kKimLee ? 10 : 0;
}

ReferenceData read_reference(const RobotConfig& config, const fs::path& log,
                             CalibrationMethod method, const CalibrationOptions& options) {
  const LogFiles files = resolve_log(log);
  ReferenceData ref;
  ref.wheels = files.dir / "wheels.csv";
  if (!files.wheels) {
    throw OptionError(fmt::format(
        "{}: not found: {{method}} {} needs the reference twists (t,vx,vy,omega) of the robot",
        OptionError::literal(ref.wheels.string()), to_name(method)));
  }
  const auto rows = read_all<WheelRow>(ref.wheels);
  ref.wheel_rows = rows.size();
  if (rows.size() < 2) {
    throw Error(fmt::format(
        "{}: {} data rows: needs at least two (the first only opens the first interval)",
        ref.wheels.string(), rows.size()));
  }
  std::vector<double> t;
  std::vector<Twist2> twist;
  for (const auto& row : rows) {
    t.push_back(row.t);
    twist.push_back(row.twist);
  }
  const ReferenceIntervals reference =
      reference_intervals(t, twist, min_interval_of(method, options));
  ref.repeated_rows = reference.repeated_rows;
  ref.intervals = reference.twists.size();

  MiceReader reader(files.mice, config);
  const double t0 = reader.start_time();
  IntervalAccumulator intervals(config.array.size(), t0, reference.times, options.max_row_interval);
  CountsCheck counts(config, t0, options.max_row_interval);
  std::size_t n_rows = 0;
  while (const auto row = reader.next()) {
    ++n_rows;
    counts.check(*row, reader);
    if (const auto error = intervals.add(*row)) {
      throw Error(
          fmt::format("{}: row {} (t = {} s): {}", log.string(), n_rows, row->t, describe(*error)));
    }
  }
  std::vector<CalibrationSample> samples;
  for (const auto& iv : intervals.covered()) {
    const CalibrationSample s{iv.sample, reference.twists[static_cast<std::size_t>(iv.index)]};
    ++ref.covered;
    if (usable_sample(s, config.array.size())) {
      samples.push_back(s);
    } else {
      ++ref.unusable;
    }
  }
  ref.measurements = measurements_of(method, options);
  ref.samples = merge_samples(samples, ref.measurements);
  return ref;
}

struct Totals {
  std::vector<Eigen::Vector2d> counts;
  std::vector<std::uint8_t> flags;
};

Totals count_totals(const fs::path& dir, const RobotConfig& config, double max_row_interval) {
  MiceReader reader(resolve_log(dir).mice, config);
  CountsCheck counts(config, reader.start_time(), max_row_interval);
  Totals t;
  t.counts.assign(static_cast<std::size_t>(config.array.size()), Eigen::Vector2d::Zero());
  t.flags.assign(static_cast<std::size_t>(config.array.size()), 0);
  while (const auto row = reader.next()) {
    counts.check(*row, reader);
    const auto i = static_cast<std::size_t>(row->sensor);
    t.counts[i] += row->counts;
    t.flags[i] |= row->flags;
  }
  return t;
}

// ------------------------------------------------------------ methods

void common_sample_lines(CalibrationSummary& r, const ReferenceData& ref,
                         const CalibrationOptions& options) {
  const double min_interval = min_interval_of(r.method, options);
  r.facts.push_back(fmt::format(
      "reference: {} ({} rows, {} intervals{}); {} within mice.csv, {} usable{}",
      ref.wheels.string(), ref.wheel_rows, ref.intervals,
      min_interval > 0.0 ? fmt::format(" of >= {} s", min_interval) : std::string(), ref.covered,
      ref.covered - ref.unusable,
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

void check_sample_count(const ReferenceData& ref, CalibrationMethod method) {
  const std::size_t need = method == CalibrationMethod::kExact ? 3 : 1;
  if (ref.samples.size() < need) {
    throw OptionError(fmt::format(
        "{}: {} usable reference interval(s) within the time span of mice.csv; {{method}} {} "
        "needs at least {}",
        OptionError::literal(ref.wheels.string()), ref.samples.size(), to_name(method), need));
  }
}

template <class Result>
Result solved(std::variant<Result, CalibrationError>&& result, const std::string& where,
              CalibrationMethod method) {
  if (const auto* e = std::get_if<CalibrationError>(&result)) {
    throw OptionError(fmt::format("{}: {{method}} {}: {}", OptionError::literal(where),
                                  to_name(method), describe(*e)));
  }
  return std::get<Result>(std::move(result));
}

SensorCalibrationReport sensor_report(const std::string& name, const SensorCalibration& c) {
  SensorCalibrationReport s;
  s.name = name;
  s.nominal = c.nominal;
  s.calibrated = c.calibrated;
  s.sigma = c.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  s.estimated = c.estimated;
  s.mirror_from_data = c.mirror_from_data;
  return s;
}

void run_kimlee(CalibrationSummary& r, const RobotConfig& config, const fs::path& log,
                const CalibrationOptions& options) {
  const ReferenceData ref = read_reference(config, log, r.method, options);
  check_sample_count(ref, r.method);
  const KimLeeCalibration cal =
      solved(calibrate_kimlee(config.array, ref.samples), log.string(), r.method);
  common_sample_lines(r, ref, options);
  const int n = config.array.size();
  r.facts.push_back(fmt::format(
      "Kim & Lee eqs. (44)-(47): S is {} x {}, rank {} of {} (singular values above {:.3g})",
      cal.measurements + 2, 2 * n, cal.rank, 2 * n, cal.threshold));
  r.facts.push_back(
      fmt::format("singular values of S: {:.6g}", fmt::join(cal.singular_values, " ")));
  r.facts.push_back(
      fmt::format("threshold = 3 x {:.3g} m/s (velocity noise) x (sqrt({}) + sqrt({}))",
                  cal.velocity_noise, cal.measurements + 2, 2 * n));
  r.facts.push_back("positions only, as in the paper: yaw, scale and mirroring stay nominal");
  for (int i = 0; i < n; ++i) {
    SensorCalibrationReport s;
    s.name = config.names[static_cast<std::size_t>(i)];
    s.nominal = config.array[i];
    s.calibrated = cal.calibrated[i];
    s.sigma(0) = std::sqrt(std::max(cal.covariance(2 * i, 2 * i), 0.0));
    s.sigma(1) = std::sqrt(std::max(cal.covariance(2 * i + 1, 2 * i + 1), 0.0));
    s.estimated = {true, true, false, false, false};
    s.residual_rms = cal.residual_rms[static_cast<std::size_t>(i)];
    r.sensors.push_back(s);
  }
  if (cal.too_few_measurements()) r.termination = CalibrationTermination::kTooFewMeasurements;
  if (cal.rank_deficient()) r.termination = CalibrationTermination::kUnderdetermined;
  if (cal.rank_deficient()) {
    r.warnings.push_back(fmt::format(
        "S is rank deficient ({} < {}): the motion determines only {} combinations of the {} "
        "position corrections; this is the minimum-norm correction (Kim & Lee's S has rank 3 for "
        "any motion to first order: row 3 of every S_k is omega (p - 2 p_nominal)); the 1-sigma "
        "covers the determined combinations only, along the other {} directions the data say "
        "nothing; the exact method gives the true positions",
        cal.rank, 2 * n, cal.rank, 2 * n, 2 * n - cal.rank));
  }
  if (cal.too_few_measurements()) {
    r.warnings.push_back(fmt::format("M = {} measurements < 2N - 2 = {} (Kim & Lee eq. (49))",
                                     cal.measurements, 2 * n - 2));
  }
  r.calibrated.array = cal.calibrated;
  r.result = cal;
}

// The model check of the exact method (ExactModelCheck): a fact line
// always; a misfit is refused (io::Error) unless forced, then a warning.
void model_check(CalibrationSummary& r, const ExactModelCheck& check, const RobotConfig& config,
                 const fs::path& log, bool force, bool camera) {
  const std::string residual =
      check.tested
          ? fmt::format(
                "residual {:.3g} counts per interval and axis against the counts' own noise {:.3g} "
                "(best rigid-motion fit): variance ratio {:.3g}, accepted up to {:.3g}",
                std::sqrt(check.residual_variance), std::sqrt(check.noise_variance),
                check.variance_ratio(), check.bound)
          : std::string("residual not tested (too few samples to know the counts' noise)");
  const std::string& worst = config.names[static_cast<std::size_t>(check.min_eigenvalue_sensor)];
  r.facts.push_back(fmt::format(
      "model check: {}; smallest information eigenvalue {:.3g} ({}), accepted down to -1", residual,
      check.min_eigenvalue, worst));
  if (!check.misfit()) return;
  std::vector<std::string> why;
  if (check.residual_too_large()) {
    why.push_back(fmt::format(
        "at the calibrated mounts the counts disagree with a rigid motion by {:.3g} counts per "
        "interval and axis, {:.3g} times their own noise of {:.3g} (accepted up to {:.3g} times)",
        std::sqrt(check.residual_variance), std::sqrt(check.variance_ratio()),
        std::sqrt(check.noise_variance), std::sqrt(check.bound)));
  }
  if (check.information_indefinite()) {
    why.push_back(fmt::format(
        "the information of sensor '{}' is not positive definite (eigenvalue {:.3g}): {} "
        "and mice.csv disagree about the motion",
        worst, check.min_eigenvalue, camera ? "camera.csv" : "wheels.csv"));
  }
  const std::string reason = fmt::format("{}", fmt::join(why, "; "));
  if (force) {
    r.warnings.push_back(
        fmt::format("the calibrated model does not explain the data, kept as forced: {}", reason));
    return;
  }
  throw OptionError(fmt::format(
      "{}: {{method}} exact: refused, the calibrated model does not explain the data: {}; is "
      "{} over the same time as mice.csv? Nothing written ({{force}} writes it anyway)",
      OptionError::literal(log.string()), OptionError::literal(reason),
      camera
          ? "camera.csv the pose (or position) of this robot's centre in the world frame (m, rad)"
          : "wheels.csv the twist of this robot in its frame (vx, vy in m/s, omega in rad/s)"));
}

// The exact method's report and result, whatever its reference (`samples`:
// how many intervals or windows it was given).
void report_exact(CalibrationSummary& r, const RobotConfig& config, const fs::path& log,
                  const CalibrationOptions& options, const ExactCalibration& cal,
                  std::size_t samples, bool camera = false) {
  const Eigen::Vector3d ref_sd = cal.noise.reference_covariance.diagonal().cwiseSqrt();
  r.facts.push_back(fmt::format(
      "reference noise (estimated, 1-sigma per interval): vx {:.4g} m/s, vy {:.4g} m/s, omega "
      "{:.4g} rad/s",
      ref_sd(0), ref_sd(1), ref_sd(2)));
  const auto& var = cal.noise.counts_variance;
  if (std::all_of(var.begin(), var.end(), [&](double v) { return v == var.front(); })) {
    r.facts.push_back(
        fmt::format("count noise (estimated, every sensor): {:.3g} counts per interval and axis",
                    std::sqrt(var.front())));
  } else {
    std::vector<std::string> count_sd;
    for (std::size_t i = 0; i < var.size(); ++i) {
      count_sd.push_back(fmt::format("{} {:.3g}", config.names[i], std::sqrt(var[i])));
    }
    r.facts.push_back(
        fmt::format("count noise (counts per interval and axis): {}", fmt::join(count_sd, ", ")));
  }
  r.facts.push_back(
      fmt::format("{} samples used, {} rejected as outliers, {} unusable (lift/overflow); "
                  "{} iterations",
                  cal.samples_used, cal.samples_rejected, cal.samples_unusable, cal.iterations));
  r.facts.push_back(
      "information: eigenvalues of the Fisher information in units of a generous mounting "
      "error (10 mm, 10 mm, 0.1 rad, 5 %, 5 %); below 1 means not excited");
  std::vector<std::string> unexcited;
  for (std::size_t i = 0; i < cal.sensors.size(); ++i) {
    const SensorCalibration& c = cal.sensors[i];
    SensorCalibrationReport s = sensor_report(config.names[i], c);
    s.residual_rms = c.residual_rms;
    s.information_eigenvalues = c.scaled_eigenvalues;
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
  r.facts.push_back(unexcited.empty()
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
  if (!cal.converged) {
    r.termination = CalibrationTermination::kNotConverged;
    r.warnings.push_back("the optimiser did not converge: the result is rough");
  }
  if (cal.model_misfit || cal.check.misfit()) r.termination = CalibrationTermination::kModelMisfit;
  model_check(r, cal.check, config, log, options.force, camera);
  if (samples < 30) {
    r.warnings.push_back(
        fmt::format("only {} samples: the noise levels (and so the 1-sigma) are rough", samples));
  }
  r.calibrated.array = cal.calibrated;
  r.result = cal;
}

// The exact fit alternated with each sensor's speed scale at options.speed_knots.
void run_exact_speed_scale(CalibrationSummary& r, const RobotConfig& config, const fs::path& log,
                           const CalibrationOptions& options, const ReferenceData& ref) {
  SpeedScaleOptions so;
  so.knots = options.speed_knots;
  auto fitted = calibrate_exact_speed_scale(config.array, ref.samples, so);
  if (const auto* e = std::get_if<SpeedScaleError>(&fitted)) {
    throw OptionError(fmt::format("{}: {{speed_knots}}: {}. Nothing written",
                                  OptionError::literal(log.string()),
                                  OptionError::literal(e->message(config.names))));
  }
  if (const auto* e = std::get_if<CalibrationError>(&fitted)) {
    throw OptionError(
        fmt::format("{}: {{method}} exact: {}", OptionError::literal(log.string()), describe(*e)));
  }
  const SpeedScaleCalibration& cal = std::get<SpeedScaleCalibration>(fitted);
  common_sample_lines(r, ref, options);
  report_exact(r, config, log, options, cal.exact, ref.samples.size());
  r.facts.push_back(fmt::format(
      "speed scale: knots {} m/s, {} rounds of mount fit and table{}; the table is 1 at the first "
      "knot, the mount's scale the resolution there",
      fmt::join(options.speed_knots, ", "), cal.rounds,
      cal.converged ? " (settled)" : " (not settled: tables still moving)"));
  if (!cal.converged) {
    r.warnings.push_back("the speed scales did not settle between mount fit and table: rough");
  }
  for (std::size_t i = 0; i < r.sensors.size() && i < cal.fits.size(); ++i) {
    r.sensors[i].speed_scale = cal.fits[i];
  }
}

void run_exact_wheels(CalibrationSummary& r, const RobotConfig& config, const fs::path& log,
                      const CalibrationOptions& options) {
  ReferenceData ref = read_reference(config, log, r.method, options);
  check_sample_count(ref, r.method);
  if (!options.speed_knots.empty()) return run_exact_speed_scale(r, config, log, options, ref);
  // A config's speed scales are undone as the pipeline does, before the
  // mounts are fitted; the calibrated mounts keep them.
  if (std::any_of(config.array.mounts().begin(), config.array.mounts().end(),
                  [](const SensorMount& m) { return m.speed_scale.active(); })) {
    ref.samples = undo_speed_scales(config.array, ref.samples);
  }
  const ExactCalibration cal =
      solved(calibrate_exact(config.array, ref.samples), log.string(), r.method);
  common_sample_lines(r, ref, options);
  report_exact(r, config, log, options, cal, ref.samples.size());
}

// camera.csv's fixes with theta (motion capture) and mice.csv as one
// CountsTrack per sensor; then calibrate_against_poses.
void run_exact_camera(CalibrationSummary& r, const RobotConfig& config, const fs::path& log,
                      const CalibrationOptions& options) {
  const LogFiles files = resolve_log(log);
  const fs::path camera = files.dir / "camera.csv";
  if (!files.camera) {
    throw OptionError(
        fmt::format("{}: not found: {{method}} exact {{reference}} camera needs the camera's fixes "
                    "of the robot "
                    "(t,x,y, with theta from motion capture)",
                    OptionError::literal(camera.string())));
  }
  // Fixes with theta (motion capture) when any row has one, else positions
  // (a ceiling camera).
  std::vector<PoseFix> fixes;
  std::vector<PositionFix> positions;
  std::size_t rows = 0;
  for (const auto& row : read_all<CameraRow>(camera)) {
    ++rows;
    if (!positions.empty() && !(row.t > positions.back().t)) {
      throw Error(fmt::format("{}: data row {} (t = {} s): not after the previous fix (t = {} s)",
                              camera.string(), rows, row.t, positions.back().t));
    }
    positions.push_back({row.t, row.position});
    if (row.theta) fixes.push_back({row.t, Pose2{row.position, *row.theta}});
  }
  if (positions.empty()) {
    throw Error(
        fmt::format("{}: no data rows: the exact calibration against the camera needs "
                    "its fixes",
                    camera.string()));
  }
  const bool with_theta = !fixes.empty();
  const int n = config.array.size();
  std::vector<CountsTrack> tracks(static_cast<std::size_t>(n),
                                  CountsTrack(options.max_row_interval));
  MiceReader reader(files.mice, config);
  CountsCheck counts(config, reader.start_time(), options.max_row_interval);
  while (const auto row = reader.next()) {
    counts.check(*row, reader);
    tracks[static_cast<std::size_t>(row->sensor)].add(
        row->t, row->counts, (row->flags & (kFlagLift | kFlagOverflow)) != 0);
  }
  std::vector<double> latency;
  for (int i = 0; i < n; ++i) latency.push_back(config.array[i].latency);
  PoseReferenceOptions po;
  po.max_offset = options.max_offset;
  po.window = options.window;
  const double camera_latency = config.camera_latency.value_or(0.0);
  auto result =
      with_theta ? calibrate_against_poses(config.array, tracks, latency, fixes, camera_latency, po)
                 : calibrate_against_positions(config.array, tracks, latency, positions,
                                               camera_latency, po);
  if (const auto* f = std::get_if<PoseReferenceFailure>(&result)) {
    std::string what = describe(f->error);
    if (f->exact_error) what += fmt::format(": {}", describe(*f->exact_error));
    if (f->error == PoseReferenceError::kNoCorrelation) {
      what = fmt::format(
          "{} (best correlation {:.3g} within {} s of the configured camera latency {} s)", what,
          f->correlation, options.max_offset, camera_latency);
    }
    throw Error(fmt::format("{}: exact against {}: {}", log.string(), camera.string(), what));
  }
  const PoseReferenceCalibration& pr = std::get<PoseReferenceCalibration>(result);
  if (with_theta) {
    r.facts.push_back(
        fmt::format("reference: {} ({} fixes with theta of {} rows), {} windows of at least {} s",
                    camera.string(), fixes.size(), rows, pr.windows, options.window));
  } else {
    const HeadingFit& h = *pr.heading;
    r.facts.push_back(fmt::format(
        "reference: {} ({} fixes, positions only), {} windows of at least {} s; the heading from "
        "the array's rotation fitted to the camera's steps over {} windows: {:.2f} +- {:.2f} deg "
        "at the first fix, drift {:.3f} +- {:.3f} deg/s, rotation scale {}, residual {:.2f} mm",
        camera.string(), rows, pr.windows, options.window, h.windows, to_degrees(h.theta0),
        to_degrees(h.theta0_sigma), to_degrees(h.drift), to_degrees(h.drift_sigma),
        h.rate_scale_estimated
            ? fmt::format("{:+.3f} +- {:.3f} %", 100.0 * h.rate_scale, 100.0 * h.rate_scale_sigma)
            : fmt::format("not seen (the array turned {:.2f} rad, less than 0.5): positions' "
                          "scale kept from the counts alone",
                          h.rotation_range),
        1e3 * h.residual_rms));
    r.facts.push_back(fmt::format(
        "gauge: the robot frame's orientation is not seen from positions; the sensors' mean yaw "
        "is kept as configured (turned back by {:.3f} deg)",
        to_degrees(h.yaw_gauge)));
  }
  r.facts.push_back(fmt::format(
      "coarse alignment: camera latency {:.4f} s (speed correlation {:.3f}, searched {} s around "
      "{} s)",
      pr.coarse_latency, pr.correlation, options.max_offset, camera_latency));
  std::vector<std::string> lat;
  for (int i = 0; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    lat.push_back(pr.latency_estimated[u]
                      ? fmt::format("{} {:.2f} +- {:.2f} ms", config.names[u], 1e3 * pr.latency[u],
                                    1e3 * pr.latency_sigma[u])
                      : fmt::format("{} {:.2f} ms (kept: no acceleration)", config.names[u],
                                    1e3 * pr.latency[u]));
  }
  r.facts.push_back(fmt::format(
      "latencies (gauge: the sensors' mean as configured): {}; camera {:.2f} +- {:.2f} ms",
      fmt::join(lat, ", "), 1e3 * pr.reference_latency, 1e3 * pr.reference_latency_sigma));
  report_exact(r, config, log, options, pr.exact, static_cast<std::size_t>(pr.windows), true);
  std::vector<SensorMount> mounts(r.calibrated.array.mounts().begin(),
                                  r.calibrated.array.mounts().end());
  for (int i = 0; i < n; ++i)
    mounts[static_cast<std::size_t>(i)].latency = pr.latency[static_cast<std::size_t>(i)];
  r.calibrated.array = SensorArray(mounts);
  r.calibrated.camera_latency = pr.reference_latency;
  r.pose_reference = pr;
}

void run_exact(CalibrationSummary& r, const RobotConfig& config, const fs::path& log,
               const CalibrationOptions& options) {
  // Default: wheels.csv when the log has it, else camera.csv when it has
  // that, else wheels (whose error names the missing file); wheels.csv
  // always for a speed scale.
  const LogFiles files = resolve_log(log);
  const ExactReference reference = options.reference.value_or(
      !files.wheels && files.camera && options.speed_knots.empty() ? ExactReference::kCamera
                                                                   : ExactReference::kWheels);
  if (reference == ExactReference::kWheels) {
    run_exact_wheels(r, config, log, options);
  } else {
    run_exact_camera(r, config, log, options);
  }
}

void run_guided(CalibrationSummary& r, const RobotConfig& config, const std::string& config_path,
                const CalibrationOptions& options) {
  const auto read = [&](const fs::path& dir, const char* what, bool all_must_count) {
    const Totals t = count_totals(dir, config, options.max_row_interval);
    for (std::size_t i = 0; i < t.counts.size(); ++i) {
      if (all_must_count && t.counts[i].isZero()) {
        throw Error(fmt::format(
            "{}: sensor '{}' counted nothing during the {}: lifted, disconnected or not in the "
            "recording?",
            dir.string(), config.names[i], what));
      }
      if ((t.flags[i] & (kFlagLift | kFlagOverflow)) != 0) {
        r.warnings.push_back(fmt::format(
            "{}: sensor '{}' reported lift or overflow during the {}: its totals may be short",
            dir.string(), config.names[i], what));
      }
    }
    return t.counts;
  };
  GuidedInput in;
  in.push_x = read(options.push_x, "push along x", true);
  if (!options.push_y.empty()) in.push_y = read(options.push_y, "push along y", true);
  in.spin = read(options.spin, "spin", false);
  in.distance = *options.distance;
  in.turns = *options.turns;
  const GuidedTolerances& tol = options.tolerances;
  const GuidedCalibration cal =
      solved(calibrate_guided(config.array, in, tol), config_path, r.method);

  r.facts.push_back(fmt::format("push along x: {}, {} m{}", options.push_x.string(), in.distance,
                                cal.push_x_reversed ? " (done backwards: detected)" : ""));
  if (in.push_y) {
    r.facts.push_back(fmt::format("push along y: {}, {} m{}", options.push_y.string(), in.distance,
                                  cal.push_y_reversed ? " (done backwards: detected)" : ""));
  }
  r.facts.push_back(fmt::format("spin: {}, {} turns {}", options.spin.string(), std::abs(in.turns),
                                cal.spin_clockwise ? "clockwise" : "counter-clockwise"));
  r.facts.push_back(fmt::format(
      "1-sigma from the procedure's tolerances: distance {} m, spin angle {} rad, spin centre {} m "
      "per axis, heading change during a push {} rad",
      tol.distance_sd, tol.turn_sd, tol.centre_sd, tol.heading_sd));
  r.facts.push_back("positions are relative to the point the robot was spun about");
  for (std::size_t i = 0; i < cal.sensors.size(); ++i) {
    SensorCalibrationReport s = sensor_report(config.names[i], cal.sensors[i]);
    s.push_misfit = cal.push_misfit[i];
    r.sensors.push_back(s);
  }
  if (cal.isotropic_scale) {
    r.warnings.push_back(
        "no push along y: each sensor's scale taken equal on both axes (1-sigma includes a 2 % "
        "difference) and mirroring judged by which puts the sensor nearer its nominal place");
  }
  if ((in.turns < 0.0) != cal.spin_clockwise) {
    r.warnings.push_back(
        fmt::format("the turns given ({}) say {}, the counts say {}: used as the counts say",
                    in.turns, in.turns < 0.0 ? "clockwise" : "counter-clockwise",
                    cal.spin_clockwise ? "clockwise" : "counter-clockwise"));
  }
  if (cal.push_x_reversed) r.warnings.push_back("the push along x went towards -x: used as such");
  if (cal.push_y_reversed) r.warnings.push_back("the push along y went towards -y: used as such");
  for (auto& w : guided_result_warnings(cal, in.distance, config.names)) {
    r.warnings.push_back(std::move(w));
  }
  r.calibrated.array = cal.calibrated;
  r.result = cal;
}

// ------------------------------------------------------------ gyro

// The array's rotation over the gyro's intervals (t[k], t[k + 1]]: mice.csv
// spread over them (IntervalAccumulator) and the least-squares twist of
// each at the calibrated mounts. An interval the array does not cover, or
// with a lift or overflow flag, reads 0 rad/s (counted; the fit drops the
// rows it spoils as outliers).
RateSeries array_rates(const RobotConfig& config, FrameSource& mice, const std::string& where,
                       const std::vector<double>& t, const CalibrationOptions& options,
                       std::size_t& gaps) {
  RateSeries ref;
  if (t.size() < 2) return ref;
  std::vector<double> dts;
  for (std::size_t k = 1; k < t.size(); ++k) dts.push_back(t[k] - t[k - 1]);
  std::nth_element(dts.begin(), dts.begin() + static_cast<std::ptrdiff_t>(dts.size() / 2),
                   dts.end());
  const double dt = dts[dts.size() / 2];
  const int n = config.array.size();
  auto created = LsEstimator::create(config.array, all_sensors(n), dt);
  if (const auto* e = std::get_if<GeometryError>(&created)) {
    throw Error(fmt::format("gyro against the array: {}", describe(*e)));
  }
  const LsEstimator& ls = std::get<LsEstimator>(created);
  IntervalAccumulator intervals(n, mice.start_time(), t, options.max_row_interval);
  while (const auto row = mice.next()) {
    if (const auto error = intervals.add(*row)) {
      throw Error(fmt::format("{}: t = {} s: {}", where, row->t, describe(*error)));
    }
  }
  ref.t = t;
  ref.rate.assign(t.size() - 1, 0.0);
  ref.velocity.assign(t.size() - 1, Eigen::Vector2d::Zero());
  std::vector<bool> set(t.size() - 1, false);
  for (const auto& iv : intervals.covered()) {
    const CalibrationSample s{iv.sample, Twist2{}};
    if (!usable_sample(s, n)) continue;
    if (const auto x = ls.estimate(iv.sample)) {
      ref.rate[static_cast<std::size_t>(iv.index)] = x->twist.omega;
      ref.velocity[static_cast<std::size_t>(iv.index)] = x->twist.v.cast<double>();
      set[static_cast<std::size_t>(iv.index)] = true;
    }
  }
  gaps = static_cast<std::size_t>(std::count(set.begin(), set.end(), false));
  return ref;
}

// The gyro's rows (t, g) fitted to `reference` (calibrate_gyro): the fit's
// facts and warnings into `r`, the calibrated imu: block into r.calibrated.
void finish_gyro(CalibrationSummary& r, GyroCalibrationReport report, const std::vector<double>& t,
                 const std::vector<double>& g, const RateSeries& reference,
                 const std::string& source, const CalibrationOptions& options) {
  const std::string imu = report.imu.string();
  const auto result = calibrate_gyro(t, g, reference);
  if (const auto* e = std::get_if<GyroCalibrationError>(&result)) {
    throw OptionError(fmt::format(
        "{}: gyro calibration against {} refused: {}. Nothing written ({{no_imu}} calibrates the "
        "mice alone)",
        OptionError::literal(imu), to_name(options.imu_reference), describe(*e)));
  }
  report.result = std::get<GyroCalibration>(result);
  const GyroCalibration& c = report.result;
  r.facts.push_back(fmt::format(
      "gyro: {} ({} rows) against {}: correlation {:.4f} at {:.2f} ms (coarse), residual RMS "
      "{:.4g} rad/s, {} of {} rows dropped as outliers, reference rate sd {:.3g} rad/s; 1-sigma "
      "{}",
      imu, t.size(), source, c.correlation, c.coarse_latency * 1e3, c.residual_rms, c.rows_rejected,
      c.rows, c.reference_sd,
      c.blocks > 0 ? fmt::format("from the residual over {} blocks of 1 s (not white)", c.blocks)
                   : std::string("from the residual variance (white)")));
  // The gyro's first and last rows usually lie just outside mice.csv: more
  // than 1 % of the intervals without the array is worth a warning.
  if (report.reference_gaps * 100 > reference.rate.size()) {
    r.warnings.push_back(fmt::format(
        "gyro: {} of {} intervals without a usable array twist (not covered, lift or overflow): "
        "read as 0 rad/s",
        report.reference_gaps, reference.rate.size()));
  } else if (report.reference_gaps > 0) {
    r.facts.push_back(fmt::format(
        "gyro: {} of {} intervals without a usable array twist (outside mice.csv, lift or "
        "overflow), read as 0 rad/s",
        report.reference_gaps, reference.rate.size()));
  }
  if (c.rows_rejected * 10 > c.rows) {
    r.warnings.push_back(fmt::format(
        "gyro: {} of {} rows disagree with the reference beyond 5 sigma (slip, the array reading "
        "nothing, a saturated gyro)",
        c.rows_rejected, c.rows));
  }
  GyroOptions calibrated = report.nominal;
  calibrated.scale = static_cast<real>(c.scale);
  calibrated.bias = static_cast<real>(c.bias);
  calibrated.latency = c.latency;
  r.calibrated.imu = calibrated;
  r.gyro = report;
}

void run_gyro(CalibrationSummary& r, const RobotConfig& config, const LogFiles& files,
              const CalibrationOptions& options) {
  GyroCalibrationReport report;
  report.reference = options.imu_reference;
  report.imu = *files.imu;
  report.nominal = config.imu.value_or(GyroOptions{});
  const auto rows = read_all<ImuRow>(*files.imu);
  std::vector<double> t, g;
  for (const auto& row : rows) {
    t.push_back(row.t);
    g.push_back(row.gz);
  }
  RateSeries reference;
  std::string source;
  if (options.imu_reference == GyroReference::kCamera) {
    // The camera's heading differenced between consecutive fixes with theta:
    // the average rate over (t[k], t[k + 1]] (rad/s), the step wrapped to
    // (-pi, pi] (a camera at 10 Hz sees less than half a turn between fixes
    // below 31 rad/s).
    if (!files.camera) {
      throw Error(fmt::format(
          "{}: not found: the gyro against the camera needs camera.csv with a theta column",
          (files.dir / "camera.csv").string()));
    }
    std::optional<double> last_theta;
    for (const auto& row : read_all<CameraRow>(*files.camera)) {
      if (!row.theta) continue;
      if (!reference.t.empty() && !(row.t > reference.t.back())) continue;
      if (last_theta) {
        const double step = std::remainder(*row.theta - *last_theta, 2.0 * std::numbers::pi);
        reference.rate.push_back(step / (row.t - reference.t.back()));
      }
      reference.t.push_back(row.t);
      last_theta = row.theta;
    }
    if (reference.rate.empty()) {
      throw Error(fmt::format(
          "{}: fewer than two fixes with theta: the gyro against the camera needs its heading",
          files.camera->string()));
    }
    source = fmt::format("the camera's heading ({}, differenced)", files.camera->string());
  } else if (options.imu_reference != GyroReference::kWheels) {
    const bool nominal = options.imu_reference == GyroReference::kArrayNominal;
    // The array at mounts this run could not determine (kimlee's minimum-norm
    // correction, a forced misfit) reads rotation wrongly by as much as they
    // are off: the gyro would be calibrated to that.
    if (!nominal && r.termination != CalibrationTermination::kConverged) {
      throw OptionError(fmt::format(
          "{}: gyro calibration against array refused: the mounts calibrated here are not usable "
          "({}), so neither is their rotation. Nothing written ({{imu_reference}} array-nominal, "
          "wheels or camera calibrates the gyro against another reference, {{no_imu}} the mice "
          "alone)",
          OptionError::literal(files.imu->string()), to_name(r.termination)));
    }
    const RobotConfig& mounts = nominal ? config : r.calibrated;
    MiceReader mice(files.mice, mounts);
    reference = array_rates(mounts, mice, mice.file(), t, options, report.reference_gaps);
    source = fmt::format("the array's rotation ({} at the {} mounts, least squares)",
                         files.mice.string(), nominal ? "nominal" : "calibrated");
  } else {
    if (!files.wheels) {
      throw Error(fmt::format("{}: not found: the gyro against the wheels needs wheels.csv",
                              (files.dir / "wheels.csv").string()));
    }
    const auto wheels = read_all<WheelRow>(*files.wheels);
    for (const auto& w : wheels) {
      if (!reference.t.empty() && !(w.t > reference.t.back())) continue;
      if (!reference.t.empty()) {
        reference.rate.push_back(w.twist.omega);
        reference.velocity.push_back(w.twist.v.cast<double>());
      }
      reference.t.push_back(w.t);
    }
    source = fmt::format("the wheels' omega ({})", files.wheels->string());
  }
  finish_gyro(r, std::move(report), t, g, reference, source, options);
}

// A recording held in memory, handed out as a log's mice.csv would be.
class RecordedRows : public FrameSource {
 public:
  RecordedRows(double start, const std::vector<SensorRow>& rows) : start_(start), rows_(rows) {}
  double start_time() override { return start_; }
  std::optional<SensorRow> next() override {
    if (next_ >= rows_.size()) return std::nullopt;
    return rows_[next_++];
  }

 private:
  double start_;
  const std::vector<SensorRow>& rows_;
  std::size_t next_ = 0;
};

// ------------------------------------------------------------ JSON

void json_vector(JsonWriter& json, std::initializer_list<double> xs) {
  json.begin_array();
  for (double x : xs) json.value(x);
  json.end_array();
}

void json_mount(JsonWriter& json, const SensorMount& m) {
  json.begin_object().key("position");
  json_vector(json, {m.position.x(), m.position.y()});
  json.member("yaw", m.yaw).key("scale");
  json_vector(json, {m.scale.x(), m.scale.y()});
  json.member("mirrored", m.mirrored).end_object();
}

template <class Vector>
void json_array(JsonWriter& json, const Vector& xs) {
  json.begin_array();
  for (const double x : xs) json.value(x);
  json.end_array();
}

}  // namespace

OptionCheck CalibrationOptions::validate() const {
  OptionsCheck c;
  c.positive("max_row_interval", max_row_interval);
  c.positive("max_offset", max_offset);
  c.positive("window", window);
  if (min_interval) c.non_negative("min_interval", *min_interval);
  if (measurements) c.at_least("measurements", *measurements, 0);
  for (const double knot : speed_knots) {
    c.require(std::isfinite(knot) && knot >= 0.0, "speed_knots", ">= 0 and finite", knot);
  }
  if (distance) c.positive("distance", *distance);
  if (turns) {
    c.require(std::isfinite(*turns), "turns", "finite", *turns)
        .require(*turns != 0.0, "turns", "!= 0", *turns);
  }
  return c.nested("tolerances", tolerances.validate()).result();
}

void check_calibration_options(CalibrationMethod method, const fs::path& log,
                               const CalibrationOptions& o) {
  const char* name = to_name(method);
  // Messages name the options as {field}: the CLI renders its flags.
  const auto need = [&](bool present, const char* what) {
    if (!present) throw OptionError(fmt::format("{{method}} {} needs {}", name, what));
  };
  const auto refuse = [&](bool present, const char* option, const char* why) {
    if (present) {
      throw OptionError(fmt::format("{{{}}} is not used by {{method}} {}: {}", option, name, why));
    }
  };
  if (method == CalibrationMethod::kGuided) {
    refuse(!log.empty(), "log",
           "guided calibration takes {push_x}, {push_y} and {spin} recordings");
    need(!o.push_x.empty(), "{push_x} DIR (a push of {distance} metres along the robot's x axis)");
    need(!o.spin.empty(), "{spin} DIR ({turns} whole turns about the robot's centre)");
    need(o.distance.has_value(), "{distance} METRES (the length of each push)");
    need(o.turns.has_value(), "{turns} K (whole turns of the spin)");
    if (!(std::isfinite(*o.distance) && *o.distance > 0.0)) {
      throw OptionError(
          fmt::format("{{distance}} {}: must be a positive number of metres", *o.distance));
    }
    if (!std::isfinite(*o.turns) || *o.turns == 0.0) {
      throw OptionError(fmt::format("{{turns}} {}: must be a non-zero number of turns", *o.turns));
    }
    refuse(o.measurements.has_value(), "measurements", "it has no reference intervals");
    refuse(o.min_interval.has_value(), "min_interval", "it has no reference intervals");
  } else {
    need(!log.empty(), "{log} DIR (a log with mice.csv and wheels.csv)");
    const char* why = "it belongs to {method} guided";
    refuse(!o.push_x.empty(), "push_x", why);
    refuse(!o.push_y.empty(), "push_y", why);
    refuse(!o.spin.empty(), "spin", why);
    refuse(o.distance.has_value(), "distance", why);
    refuse(o.turns.has_value(), "turns", why);
  }
  if (!o.speed_knots.empty()) {
    if (method != CalibrationMethod::kExact) {
      throw OptionError(fmt::format(
          "{{speed_knots}} is used by {{method}} exact only, not by {{method}} {}", name));
    }
    if (o.reference == ExactReference::kCamera) {
      throw OptionError(
          "{speed_knots} needs the reference twists of wheels.csv, not {reference} camera");
    }
    const std::size_t n = o.speed_knots.size();
    if (n < static_cast<std::size_t>(SpeedScale::kMinKnots) ||
        n > static_cast<std::size_t>(SpeedScale::kMaxKnots)) {
      throw OptionError(fmt::format("{{speed_knots}}: {} knots, needs {} to {}", n,
                                    SpeedScale::kMinKnots, SpeedScale::kMaxKnots));
    }
    for (std::size_t k = 1; k < n; ++k) {
      if (!(o.speed_knots[k] > o.speed_knots[k - 1])) {
        throw OptionError(
            fmt::format("{{speed_knots}}: knots must be strictly increasing ({} after {} m/s)",
                        o.speed_knots[k], o.speed_knots[k - 1]));
      }
    }
  }
  if (const auto e = o.validate()) throw Error(fmt::format("invalid option: {}", e->message()));
}

void calibrate_spin_gyro(CalibrationSummary& r, const RobotConfig& config,
                         const SpinRecording& spin, const CalibrationOptions& options) {
  GyroCalibrationReport report;
  report.reference = GyroReference::kArray;
  report.imu = spin.imu_where;
  report.nominal = config.imu.value_or(GyroOptions{});
  if (r.termination != CalibrationTermination::kConverged) {
    throw OptionError(fmt::format(
        "{}: gyro calibration against array refused: the mounts calibrated here are not usable "
        "({}), so neither is their rotation",
        OptionError::literal(spin.imu_where), to_name(r.termination)));
  }
  std::vector<double> t, g;
  for (const auto& row : spin.imu) {
    t.push_back(row.t);
    g.push_back(row.gz);
  }
  RecordedRows mice(spin.start, spin.mice);
  const RateSeries reference =
      array_rates(r.calibrated, mice, spin.mice_where, t, options, report.reference_gaps);
  const std::string source = fmt::format(
      "the array's rotation ({} at the calibrated mounts, least squares)", spin.mice_where);
  CalibrationOptions array_options = options;
  array_options.imu_reference = GyroReference::kArray;
  finish_gyro(r, std::move(report), t, g, reference, source, array_options);
}

CalibrationSummary calibrate_log(const RobotConfig& config, const std::string& config_path,
                                 const fs::path& log, CalibrationMethod method,
                                 const CalibrationOptions& options) {
  check_calibration_options(method, log, options);
  CalibrationSummary r;
  r.method = method;
  r.calibrated = config;
  switch (method) {
    case CalibrationMethod::kKimLee:
      run_kimlee(r, config, log, options);
      break;
    case CalibrationMethod::kExact:
      run_exact(r, config, log, options);
      break;
    case CalibrationMethod::kGuided:
      run_guided(r, config, config_path, options);
      break;
  }
  // The gyro: against the log (kimlee, exact) or the spin's recording
  // (guided: the array at the mounts the pushes and the spin gave).
  if (options.imu) {
    const LogFiles files = resolve_log(method == CalibrationMethod::kGuided ? options.spin : log);
    if (files.imu) run_gyro(r, config, files, options);
  }
  for (const auto& s : r.sensors) {
    // A fit that ran away (a scale through zero: a flipped axis) gives no
    // sensor a config can hold: refused, --force or not.
    const MountVector p = mount_parameters(s.calibrated);
    if (!p.allFinite() || !(s.calibrated.scale.minCoeff() > 0.0)) {
      throw OptionError(fmt::format(
          "{}: {{method}} {}: refused, sensor '{}' calibrated to position ({:.4g}, {:.4g}) m, yaw "
          "{:.4g} rad, scale ({:.4g}, {:.4g}): not a sensor mount (a scale must be positive); the "
          "data do not fit the model. Nothing written",
          OptionError::literal(method == CalibrationMethod::kGuided ? config_path : log.string()),
          to_name(method), OptionError::literal(s.name), p(0), p(1), p(2), p(3), p(4)));
    }
    for (auto& w : plausibility_warnings(s.name, s.nominal, s.calibrated)) {
      r.warnings.push_back(std::move(w));
    }
  }
  r.usable = r.termination == CalibrationTermination::kConverged;
  // An optimiser stopped before converging gives mounts nobody should drive
  // on: refused unless --force, as a misfit is.
  if (r.termination == CalibrationTermination::kNotConverged && !options.force) {
    throw OptionError(fmt::format(
        "{}: {{method}} {}: refused, the fit did not converge (its mounts would be arbitrary). "
        "Nothing written ({{force}} writes it anyway)",
        OptionError::literal(method == CalibrationMethod::kGuided ? config_path : log.string()),
        to_name(method)));
  }
  return r;
}

std::string CalibrationSummary::brief_report() const {
  double position = 0.0, yaw = 0.0, scale = 0.0;
  for (const auto& s : sensors) {
    position = std::max({position, s.sigma(0), s.sigma(1)});
    yaw = std::max(yaw, s.sigma(2));
    scale = std::max({scale, s.sigma(3), s.sigma(4)});
  }
  return fmt::format(
      "moa calibrate --method {}: {} sensors; largest 1-sigma: position {:.3f} mm, yaw {:.3f} "
      "deg, scale {:.2f} %; {} warning{}",
      to_name(method), sensors.size(), position * 1e3, to_degrees(yaw), scale * 100.0,
      warnings.size(), warnings.size() == 1 ? "" : "s");
}

std::string CalibrationSummary::full_report() const {
  std::string text;
  auto out = std::back_inserter(text);
  fmt::format_to(out, "moa calibrate --method {}: {} ({})\n", to_name(method),
                 usable ? "usable" : "not usable", to_name(termination));
  for (const auto& line : facts) fmt::format_to(out, "  {}\n", line);
  for (const auto& s : sensors) {
    fmt::format_to(out, "\nsensor {}\n", s.name);
    fmt::format_to(out, "  {:<14} {:>12} {:>12} {:>12}\n", "parameter", "nominal", "calibrated",
                   "1-sigma");
    const MountVector a = mount_parameters(s.nominal);
    const MountVector b = mount_parameters(s.calibrated);
    const std::array<const char*, kMountParameters> labels{"position x m", "position y m",
                                                           "yaw deg", "scale x", "scale y"};
    for (int p = 0; p < kMountParameters; ++p) {
      const double unit = p == 2 ? to_degrees(1.0) : 1.0;
      const int digits = p < 2 ? 5 : 4;
      const std::string sigma = s.estimated[static_cast<std::size_t>(p)]
                                    ? fmt::format("{:.{}f}", s.sigma(p) * unit, p < 2 ? 6 : 5)
                                    : std::string("kept");
      fmt::format_to(out, "  {:<14} {:>12.{}f} {:>12.{}f} {:>12}\n",
                     labels[static_cast<std::size_t>(p)], a(p) * unit, digits, b(p) * unit, digits,
                     sigma);
    }
    fmt::format_to(out, "  {:<14} {:>12} {:>12} {:>12}\n", "mirrored", yes_no(s.nominal.mirrored),
                   yes_no(s.calibrated.mirrored), s.mirror_from_data ? "from data" : "kept");
    if (s.residual_rms) {
      fmt::format_to(out, "  {:<14} {:.3f} mm/s\n", "residual RMS", *s.residual_rms * 1e3);
    }
    if (s.push_misfit) {
      fmt::format_to(out, "  {:<14} {:.3f} mm\n", "push misfit", *s.push_misfit * 1e3);
    }
    if (s.information_eigenvalues) {
      fmt::format_to(out, "  {:<14} {:.3g}\n", "information",
                     fmt::join(*s.information_eigenvalues, " "));
    }
    if (s.speed_scale) {
      const SpeedScaleFit& f = *s.speed_scale;
      fmt::format_to(out, "  speed scale ({} windows, fastest {:.3f} m/s, residual {:.3f} mm)\n",
                     f.windows, f.max_speed, f.residual_rms * 1e3);
      fmt::format_to(out, "  {:<14} {:>12} {:>12} {:>12}\n", "knot m/s", "ratio", "1-sigma",
                     "windows");
      for (std::size_t k = 0; k < f.knots.size(); ++k) {
        fmt::format_to(out, "  {:<14.4g} {:>12.5f} {:>12} {:>12}\n", f.knots[k], f.ratios[k],
                       k == 0 ? std::string("(gauge)") : fmt::format("{:.5f}", f.sigma[k]),
                       f.coverage[k]);
      }
    }
  }
  if (gyro) fmt::format_to(out, "\n{}", gyro->table());
  fmt::format_to(out, "\n");
  if (warnings.empty()) {
    fmt::format_to(out, "warnings: none\n");
  } else {
    fmt::format_to(out, "warnings:\n");
    for (const auto& w : warnings) fmt::format_to(out, "  {}\n", w);
  }
  return text;
}

std::string GyroCalibrationReport::table() const {
  const GyroCalibration& c = result;
  std::string text;
  auto out = std::back_inserter(text);
  fmt::format_to(out, "gyro against the {}\n", to_name(reference));
  fmt::format_to(out, "  {:<14} {:>12} {:>12} {:>12}\n", "parameter", "nominal", "calibrated",
                 "1-sigma");
  fmt::format_to(out, "  {:<14} {:>12.5f} {:>12.5f} {:>12.5f}\n", "scale", nominal.scale, c.scale,
                 c.scale_sigma());
  fmt::format_to(out, "  {:<14} {:>12.6f} {:>12.6f} {:>12.6f}\n", "bias rad/s", nominal.bias,
                 c.bias, c.bias_sigma());
  fmt::format_to(out, "  {:<14} {:>12.3f} {:>12.3f} {:>12.3f}\n", "latency ms",
                 nominal.latency * 1e3, c.latency * 1e3, c.latency_sigma() * 1e3);
  return text;
}

std::string CalibrationSummary::to_json(std::string_view out) const {
  JsonWriter json;
  json.begin_object()
      .member("method", to_name(method))
      .member("usable", usable)
      .member("termination", to_name(termination));
  if (!out.empty()) json.member("out", out);
  if (const auto* k = std::get_if<KimLeeCalibration>(&result)) {
    json.member("samples", k->measurements)
        .member("rank", k->rank)
        .member("unknowns", 2 * calibrated.array.size())
        .member("threshold", k->threshold)
        .member("velocity_noise_m_s", k->velocity_noise)
        .key("singular_values");
    json_array(json, k->singular_values);
  } else if (const auto* e = std::get_if<ExactCalibration>(&result)) {
    const Eigen::Vector3d ref_sd = e->noise.reference_covariance.diagonal().cwiseSqrt();
    json.member("samples", e->samples_used)
        .member("samples_rejected", e->samples_rejected)
        .member("samples_unusable", e->samples_unusable)
        .key("reference_noise_sd");
    json_array(json, ref_sd);
    json.member("converged", e->converged);
    if (pose_reference) {
      // Against the camera: the latencies (s), gauge the sensors' configured mean.
      const PoseReferenceCalibration& p = *pose_reference;
      json.key("camera")
          .begin_object()
          .member("latency_s", p.reference_latency)
          .member("latency_sigma_s", p.reference_latency_sigma)
          .member("coarse_latency_s", p.coarse_latency)
          .member("correlation", p.correlation)
          .member("windows", p.windows)
          .key("sensor_latency_s");
      json_array(json, p.latency);
      json.key("sensor_latency_sigma_s");
      json_array(json, p.latency_sigma);
      json.member("positions_only", p.heading.has_value());
      if (p.heading) {
        // The heading reconstructed from the array (docs/calibration.md, "Positions only").
        const HeadingFit& h = *p.heading;
        json.key("heading")
            .begin_object()
            .member("theta0_rad", h.theta0)
            .member("theta0_sigma_rad", h.theta0_sigma)
            .member("drift_rad_per_s", h.drift)
            .member("drift_sigma_rad_per_s", h.drift_sigma)
            .member("rate_scale_estimated", h.rate_scale_estimated)
            .member("rate_scale", h.rate_scale)
            .member("rate_scale_sigma", h.rate_scale_sigma)
            .member("rotation_range_rad", h.rotation_range)
            .member("residual_rms_m", h.residual_rms)
            .member("windows", h.windows)
            .member("yaw_gauge_rad", h.yaw_gauge)
            .end_object();
      }
      json.end_object();
    }
  } else if (const auto* g = std::get_if<GuidedCalibration>(&result)) {
    json.member("isotropic_scale", g->isotropic_scale)
        .member("push_x_reversed", g->push_x_reversed)
        .member("push_y_reversed", g->push_y_reversed)
        .member("spin_clockwise", g->spin_clockwise)
        .key("centroid_shift");
    json_array(json, g->centroid_shift);
  }
  json.key("sensors").begin_array();
  for (const auto& s : sensors) {
    json.begin_object().member("name", s.name).key("nominal");
    json_mount(json, s.nominal);
    json.key("calibrated");
    json_mount(json, s.calibrated);
    json.key("sigma").begin_object().key("position");
    json_vector(json, {s.sigma(0), s.sigma(1)});
    json.member("yaw", s.sigma(2)).key("scale");
    json_vector(json, {s.sigma(3), s.sigma(4)});
    json.end_object();
    json.key("estimated")
        .begin_object()
        .member("position_x", s.estimated[0])
        .member("position_y", s.estimated[1])
        .member("yaw", s.estimated[2])
        .member("scale_x", s.estimated[3])
        .member("scale_y", s.estimated[4])
        .end_object();
    json.member("mirror_from_data", s.mirror_from_data);
    if (s.residual_rms) json.member("residual_rms_m_s", *s.residual_rms);
    if (s.push_misfit) json.member("push_misfit_m", *s.push_misfit);
    if (s.information_eigenvalues) {
      json.key("information_eigenvalues");
      json_array(json, *s.information_eigenvalues);
    }
    if (s.speed_scale) {
      json.key("speed_scale").begin_object().key("speeds_m_s");
      json_array(json, s.speed_scale->knots);
      json.key("ratios");
      json_array(json, s.speed_scale->ratios);
      json.key("sigma");
      json_array(json, s.speed_scale->sigma);
      json.key("windows");
      json_array(json, s.speed_scale->coverage);
      json.end_object();
    }
    json.end_object();
  }
  json.end_array();
  if (gyro) {
    const GyroCalibration& c = gyro->result;
    json.key("gyro")
        .begin_object()
        .member("reference", to_name(gyro->reference))
        .member("imu", gyro->imu.string())
        .member("scale", c.scale)
        .member("bias_rad_s", c.bias)
        .member("latency_s", c.latency)
        .key("sigma")
        .begin_object()
        .member("scale", c.scale_sigma())
        .member("bias_rad_s", c.bias_sigma())
        .member("latency_s", c.latency_sigma())
        .end_object()
        .member("correlation", c.correlation)
        .member("coarse_latency_s", c.coarse_latency)
        .member("residual_rms_rad_s", c.residual_rms)
        .member("reference_sd_rad_s", c.reference_sd)
        .member("rows", c.rows)
        .member("rows_rejected", c.rows_rejected)
        .member("reference_gaps", gyro->reference_gaps)
        .end_object();
  }
  json.key("warnings").begin_array();
  for (const auto& w : warnings) json.value(w);
  json.end_array().end_object();
  return json.str();
}

}  // namespace moa::io
