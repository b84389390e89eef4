#include "moa/io/odometry_run.hpp"

#include "moa/io/self_calibration_csv.hpp"

#include <fmt/core.h>

#include <memory>

#include "moa/io/csv.hpp"
#include "moa/io/error.hpp"
#include "moa/io/log.hpp"
#include "moa/io/odometry_csv.hpp"

namespace moa::io {
namespace fs = std::filesystem;

OdometryOptions resolve_odometry_options(OdometryOptions o, std::string_view estimator,
                                         const std::vector<std::string>& sensors, bool no_wheels,
                                         const RobotConfig& config,
                                         const std::string& config_path) {
  const auto kind = estimator_from_name(estimator);
  if (!kind) throw Error(fmt::format("--estimator: unknown estimator '{}'", estimator));
  o.estimator = *kind;
  o.use_wheels = !no_wheels;
  if (o.estimator == EstimatorKind::kWheels && no_wheels) {
    throw Error("--estimator wheels and --no-wheels exclude each other");
  }
  if (!sensors.empty()) {
    o.sensors = 0;
    for (const auto& name : sensors) {
      const auto i = config.index_of(name);
      if (!i) {
        std::string names;
        for (const auto& n : config.names) names += (names.empty() ? "" : ", ") + n;
        throw Error(
            fmt::format("--sensors: unknown sensor '{}' ({} has {})", name, config_path, names));
      }
      if (contains(o.sensors, *i)) {
        throw Error(fmt::format("--sensors: sensor '{}' named twice", name));
      }
      o.sensors |= SensorMask{1} << *i;
    }
  }
  if (const char* e = o.validate(); *e) throw Error(fmt::format("invalid option: {}", e));
  return o;
}

std::vector<fs::path> LogFiles::files() const {
  std::vector<fs::path> out{mice};
  for (const auto& f : {wheels, camera, truth, faults}) {
    if (f) out.push_back(*f);
  }
  return out;
}

LogFiles resolve_log(const fs::path& log) {
  std::error_code ec;
  LogFiles files;
  if (fs::is_directory(log, ec)) {
    files.dir = log;
    files.mice = log / "mice.csv";
  } else {
    files.dir = log.parent_path().empty() ? fs::path(".") : log.parent_path();
    files.mice = log;
  }
  if (!fs::is_regular_file(files.mice, ec)) {
    throw Error(
        fmt::format("{}: no such file (a log directory holds mice.csv)", files.mice.string()));
  }
  const auto optional = [&](const char* name) -> std::optional<fs::path> {
    const fs::path p = files.dir / name;
    if (fs::exists(p, ec)) return p;
    return std::nullopt;
  };
  files.wheels = optional("wheels.csv");
  files.camera = optional("camera.csv");
  files.truth = optional("truth.csv");
  files.faults = optional("faults.csv");
  return files;
}

std::unique_ptr<Odometry> make_odometry(const RobotConfig& config, const std::string& config_path,
                                        double t0, const OdometryOptions& given) {
  // The robot's limits, when its config gives them, for the motion prior.
  OdometryOptions options = given;
  if (config.limits) options.consensus.limits = *config.limits;
  if (const char* e = options.validate(); *e) throw Error(fmt::format("invalid option: {}", e));
  const SensorMask beyond = options.sensors & ~all_sensors(config.array.size());
  if (beyond != 0 && options.sensors != ~SensorMask{0}) {
    throw Error(fmt::format("sensors: selection names a sensor beyond the {} of {}",
                            config.array.size(), config_path));
  }
  auto odometry = std::make_unique<Odometry>(config.array, t0, options);
  if (const auto e = odometry->geometry_error()) {
    throw Error(fmt::format("{}: {} (estimator {})", config_path, describe(*e),
                            describe(options.estimator)));
  }
  return odometry;
}

namespace {

/// faults.csv (written by `moa simulate`): one row per mice.csv row, in the
/// same order, with the simulator's fault bits of that row.
class FaultsReader {
 public:
  FaultsReader(const fs::path& file, const RobotConfig& config)
      : csv_(file),
        config_(config),
        t_(csv_.required_column("t")),
        sensor_(csv_.required_column("sensor")),
        faults_(csv_.required_column("faults")) {}

  /// The fault bits of the row twinned with `row`.
  std::uint8_t next(const SensorRow& row) {
    if (!csv_.next()) csv_.fail("ends before mice.csv (one row per mice.csv row)");
    const double t = csv_.number(t_);
    const auto sensor = config_.index_of(csv_.field(sensor_));
    if (t != row.t || !sensor || *sensor != row.sensor) {
      csv_.fail(fmt::format("row (t={}, sensor {}) does not match mice.csv's (t={}, sensor {})", t,
                            printable(csv_.field(sensor_)), row.t,
                            config_.names[static_cast<std::size_t>(row.sensor)]));
    }
    return static_cast<std::uint8_t>(csv_.integer(faults_, 0, 255));
  }

 private:
  CsvReader csv_;
  const RobotConfig& config_;
  std::size_t t_, sensor_, faults_;
};

}  // namespace

OdometryRun run_odometry(const RobotConfig& config, const std::string& config_path,
                         const LogFiles& log, const OdometryOptions& options,
                         const StepCallback& on_step, const ProgressCallback& progress) {
  MiceReader mice(log.mice, config);
  const std::string where = log.mice.string();
  std::unique_ptr<WheelsReader> wheels;
  if (options.use_wheels && log.wheels) wheels = std::make_unique<WheelsReader>(*log.wheels);
  std::unique_ptr<CameraReader> camera;
  if (options.fuse_camera) {
    if (!log.camera) {
      throw Error(fmt::format("{}: camera fusion needs camera.csv in the log",
                              (log.dir / "camera.csv").string()));
    }
    camera = std::make_unique<CameraReader>(*log.camera);
  }
  std::unique_ptr<FaultsReader> faults;
  if (options.estimator == EstimatorKind::kOracle) {
    if (!log.faults) {
      throw Error(fmt::format("{}: the oracle needs the simulator's faults.csv",
                              (log.dir / "faults.csv").string()));
    }
    faults = std::make_unique<FaultsReader>(*log.faults, config);
  }

  OdometryRun run;
  run.t0 = mice.start_time();
  run.t_end = run.t0;
  const auto odometry = make_odometry(config, config_path, run.t0, options);
  SensorMask runaway_seen = 0;
  const auto sink = [&](const OdometryStep& step) {
    if (step.calibration != nullptr) {
      for (int i = 0; i < config.array.size(); ++i) {
        if (step.estimate.excluded[static_cast<std::size_t>(i)] != Exclusion::kCalibration ||
            contains(runaway_seen, i)) {
          continue;
        }
        runaway_seen |= SensorMask{1} << i;
        const auto& c = (*step.calibration_filter)[static_cast<std::size_t>(i)];
        run.warnings.push_back(fmt::format(
            "sensor '{}': its self-calibration ran away (scale {:.3f}, {:.3f}, yaw offset {:.3f} "
            "rad at t = {} s; bounds {} and {} rad): excluded as 'calibration' while beyond",
            config.names[static_cast<std::size_t>(i)], c.scale_x, c.scale_y, c.yaw_offset, step.t(),
            options.self_calibration.runaway_scale, options.self_calibration.runaway_yaw));
      }
    }
    on_step(step);
  };

  std::optional<WheelRow> wheel = wheels ? wheels->next() : std::nullopt;
  std::optional<CameraRow> fix = camera ? camera->next() : std::nullopt;
  const auto fail = [&](const std::string& file, double t, OdometryError e) {
    const std::string detail =
        e == OdometryError::kRow ? describe(odometry->row_error()) : describe(e);
    throw Error(fmt::format("{}: row at t = {} s: {}", file, t, detail));
  };
  // Feeds the camera fixes and wheel rows up to time t, in time order.
  const auto feed_until = [&](double t) {
    while (fix && fix->t <= t) {
      const CameraFix f{fix->t, fix->position, fix->theta, fix->sigma};
      if (const auto e = odometry->push_fix(f)) fail(log.camera->string(), fix->t, *e);
      fix = camera->next();
    }
    while (wheel && wheel->t <= t) {
      if (const auto e = odometry->push_wheels(wheel->t, wheel->twist, sink)) {
        fail(log.wheels->string(), wheel->t, *e);
      }
      wheel = wheels->next();
    }
  };

  while (auto row = mice.next()) {
    if (faults) row->faults = faults->next(*row);
    feed_until(row->t);
    if (const auto e = odometry->push(*row, sink)) {
      fail(fmt::format("{}:{}", where, mice.line()), row->t, *e);
    }
    run.t_end = row->t;
    ++run.rows;
    if (progress && (run.rows & 0xfff) == 0) progress(run.rows, row->t);
  }
  // The stream ends with the last mice row: the last epochs use the wheel
  // rows and fixes up to its time.
  feed_until(run.t_end);
  // Sensors of the config that never reported: a silent sensor reads as
  // still, which least squares averages in (metres off on a moving robot).
  const auto& rows = mice.rows_per_sensor();
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (rows[i] != 0 || !contains(options.sensors, static_cast<int>(i))) continue;
    const std::string& name = config.names[i];
    if (options.estimator == EstimatorKind::kLs || options.estimator == EstimatorKind::kOracle) {
      throw Error(fmt::format(
          "{}: sensor '{}' of {} never reports: {} would take it as still; leave it out "
          "(--sensors) or use a robust estimator (consensus, sekimori)",
          where, name, config_path, describe(options.estimator)));
    }
    if (options.estimator != EstimatorKind::kWheels) {
      run.warnings.push_back(fmt::format(
          "{}: sensor '{}' of {} never reports: the {} estimator saw it as a still sensor", where,
          name, config_path, describe(options.estimator)));
    }
  }
  odometry->finish(run.t_end, sink);
  run.steps = odometry->steps();
  run.fixes = odometry->fixes();
  return run;
}

OdometryRun write_odometry(const RobotConfig& config, const std::string& config_path,
                           const LogFiles& log, const OdometryOptions& options, const fs::path& out,
                           const ProgressCallback& progress, const fs::path& calibration_out) {
  std::unique_ptr<SelfCalibrationCsvWriter> calibration;
  if (!calibration_out.empty() && options.self_calibration.enabled) {
    calibration = std::make_unique<SelfCalibrationCsvWriter>(
        calibration_out, config.names, options.sensors & all_sensors(config.array.size()));
  }
  OdometryCsvWriter writer(out, config.names, options.fuse_camera,
                           options.fuse_camera && options.ekf.estimate_scale);
  const OdometryRun run = run_odometry(
      config, config_path, log, options,
      [&](const OdometryStep& step) {
        writer.write(step);
        if (calibration) calibration->write(step);
      },
      progress);
  writer.commit();
  if (calibration) calibration->commit();
  return run;
}

}  // namespace moa::io
