#include "moa/runs/odometry_run.hpp"

#include "moa/formats/self_calibration_csv.hpp"

#include <fmt/core.h>

#include <exception>
#include <memory>
#include <thread>

#include "batch_queue.hpp"
#include "moa/formats/csv.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/log.hpp"
#include "moa/formats/odometry_csv.hpp"

namespace moa::io {
namespace fs = std::filesystem;

OdometryOptions resolve_odometry_options(OdometryOptions o, std::string_view estimator,
                                         const std::vector<std::string>& sensors, bool no_wheels,
                                         const RobotConfig& config,
                                         const std::string& config_path) {
  const auto kind = from_name<EstimatorKind>(estimator);
  if (!kind) throw Error(fmt::format("--estimator: unknown estimator '{}'", estimator));
  o.estimator = *kind;
  o.use_wheels = !no_wheels;
  if (o.estimator == EstimatorKind::kWheels && no_wheels) {
    throw Error("--estimator wheels and --no-wheels exclude each other");
  }
  if (o.self_calibration.enabled && o.self_calibration.gauge == SelfCalibrationGauge::kWheels &&
      no_wheels) {
    throw Error("--self-calibration-gauge wheels and --no-wheels exclude each other");
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
  if (const auto e = o.validate()) throw Error(fmt::format("invalid option: {}", e->message()));
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
  if (const auto e = options.validate()) {
    throw Error(fmt::format("invalid option: {}", e->message()));
  }
  const SensorMask beyond = options.sensors & ~all_sensors(config.array.size());
  if (beyond != 0 && options.sensors != ~SensorMask{0}) {
    throw Error(fmt::format("sensors: selection names a sensor beyond the {} of {}",
                            config.array.size(), config_path));
  }
  auto odometry = std::make_unique<Odometry>(config.array, t0, options);
  if (const auto e = odometry->geometry_error()) {
    throw Error(fmt::format("{}: {} (estimator {})", config_path, describe(*e),
                            to_name(options.estimator)));
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

// The threads of a replay: parsing mice.csv, running the pipeline and
// writing odometry.csv take about a third of the time each (docs/
// performance.md), so the parse and the write run beside the pipeline, on
// the machine's other cores. The core stays single-threaded: the pipeline
// runs on the caller's thread, and only rows and steps change threads, in
// batches (runs/batch_queue.hpp), in order. Records are copied into
// preallocated batches: no allocation per row or step.
//
// Each side can work ahead by 8 batches, about 5 ms of the pipeline (0.65
// us an epoch of four sensors at 1 kHz, `moa bench --replay`): a scheduler
// slice, so that a thread descheduled on a loaded machine rarely stalls the
// others.
constexpr std::size_t kBatches = 8;
constexpr std::size_t kRowBatch = 4096;   // mice rows per batch (about 230 kB)
constexpr std::size_t kStepBatch = 1024;  // odometry steps per batch (about 390 kB)

/// A mice.csv row as the parser thread hands it over: the row with its
/// faults.csv bits, and its line for the error messages ("mice.csv:LINE").
struct MiceRecord {
  SensorRow row;
  std::size_t line = 0;
};

/// Parses mice.csv (and faults.csv's twin rows) on a thread of its own. A
/// parse error reaches next() after the rows before it, as the same
/// io::Error. Destroyed before the end (an exception of the pipeline), it
/// stops the parser and joins it.
class MiceReaderThread {
 public:
  MiceReaderThread(MiceReader& mice, FaultsReader* faults)
      : mice_(mice), faults_(faults), thread_([this] { parse(); }) {}
  ~MiceReaderThread() {
    if (thread_.joinable()) {
      queue_.stop();
      thread_.join();
    }
  }
  MiceReaderThread(const MiceReaderThread&) = delete;
  MiceReaderThread& operator=(const MiceReaderThread&) = delete;

  /// The next row in file order, valid until the next call; nullptr at the
  /// end. Rethrows the parser's error where it stopped.
  const MiceRecord* next() {
    if (batch_ != nullptr) {
      if (index_ < batch_->size()) return &(*batch_)[index_++];
      queue_.release();
      batch_ = nullptr;
    }
    batch_ = queue_.next();  // never an empty batch
    index_ = 0;
    if (batch_ == nullptr) return nullptr;
    return &(*batch_)[index_++];
  }
  /// After next() returned nullptr: the parser is done with the readers
  /// (MiceReader::rows_per_sensor() may be read).
  void join() { thread_.join(); }

 private:
  void parse() {
    std::vector<MiceRecord>* batch = nullptr;
    try {
      while (auto row = mice_.next()) {
        if (faults_ != nullptr) row->faults = faults_->next(*row);
        if (batch == nullptr) {
          batch = queue_.acquire();
          if (batch == nullptr) return;  // the pipeline stopped
        }
        batch->push_back({*row, mice_.line()});
        if (batch->size() == queue_.capacity()) {
          queue_.submit();
          batch = nullptr;
        }
      }
      if (batch != nullptr) queue_.submit();
      queue_.close();
    } catch (...) {
      // The rows before the error first, then the error.
      if (batch != nullptr && !batch->empty()) queue_.submit();
      queue_.close(std::current_exception());
    }
  }

  MiceReader& mice_;
  FaultsReader* faults_;
  BatchQueue<MiceRecord> queue_{kBatches, kRowBatch};
  const std::vector<MiceRecord>* batch_ = nullptr;  ///< being consumed
  std::size_t index_ = 0;                           ///< next record of batch_
  std::thread thread_;                              ///< last: starts with the rest built
};

/// A step as the writer thread gets it: a copy of the sink's step without
/// its pointers (valid only during the sink call), and the step's time (s).
struct StepRecord {
  double t = 0.0;
  OdometryStep step;
};

/// Writes odometry.csv's rows on a thread of its own. A write error (a full
/// disk) is rethrown by the write() after it or by finish(); destroyed
/// before finish() (an exception of the pipeline), it stops the writer and
/// joins it, and the file, never committed, does not appear.
class StepWriterThread {
 public:
  explicit StepWriterThread(OdometryCsvWriter& writer)
      : writer_(writer), thread_([this] { write_batches(); }) {}
  ~StepWriterThread() {
    if (thread_.joinable()) {
      queue_.stop();
      thread_.join();
    }
  }
  StepWriterThread(const StepWriterThread&) = delete;
  StepWriterThread& operator=(const StepWriterThread&) = delete;

  void write(const OdometryStep& step) {
    if (batch_ == nullptr) {
      batch_ = queue_.acquire();  // rethrows the writer's error
      if (batch_ == nullptr) throw Error("odometry.csv: the writer thread stopped");
    }
    batch_->push_back({step.t(), step});
    OdometryStep& copy = batch_->back().step;
    copy.sample = nullptr;
    copy.calibration = nullptr;
    copy.calibration_filter = nullptr;
    if (batch_->size() == queue_.capacity()) {
      queue_.submit();
      batch_ = nullptr;
    }
  }
  /// Writes the rest and joins the writer; rethrows its error. The writer
  /// may then be committed.
  void finish() {
    if (batch_ != nullptr && !batch_->empty()) queue_.submit();
    batch_ = nullptr;
    queue_.close();
    thread_.join();
    if (error_) std::rethrow_exception(error_);
  }

 private:
  void write_batches() {
    try {
      while (const auto* batch = queue_.next()) {
        for (const StepRecord& r : *batch) writer_.write(r.t, r.step);
        queue_.release();
      }
    } catch (...) {
      error_ = std::current_exception();  // read by finish() after the join
      queue_.stop(error_);
    }
  }

  OdometryCsvWriter& writer_;
  BatchQueue<StepRecord> queue_{kBatches, kStepBatch};
  std::vector<StepRecord>* batch_ = nullptr;  ///< being filled
  std::exception_ptr error_;
  std::thread thread_;  ///< last: starts with the rest built
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
        run.summary.warnings.push_back(fmt::format(
            "sensor '{}': its self-calibration ran away (scale {:.3f}, {:.3f}, yaw offset {:.3f} "
            "rad at t = {} s; bounds {} and {} rad): excluded as 'calibration' while beyond",
            config.names[static_cast<std::size_t>(i)], c.scale_x, c.scale_y, c.yaw_offset, step.t(),
            options.self_calibration.runaway_scale, options.self_calibration.runaway_yaw));
      }
    }
    run.summary.add(step, config.array.size());
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

  MiceReaderThread parsed(mice, faults.get());
  while (const MiceRecord* record = parsed.next()) {
    const SensorRow& row = record->row;
    feed_until(row.t);
    if (const auto e = odometry->push(row, sink)) {
      fail(fmt::format("{}:{}", where, record->line), row.t, *e);
    }
    run.t_end = row.t;
    ++run.rows;
    if (progress && (run.rows & 0xfff) == 0) progress(run.rows, row.t);
  }
  parsed.join();
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
          where, name, config_path, to_name(options.estimator)));
    }
    if (options.estimator != EstimatorKind::kWheels) {
      run.summary.warnings.push_back(fmt::format(
          "{}: sensor '{}' of {} never reports: the {} estimator saw it as a still sensor", where,
          name, config_path, to_name(options.estimator)));
    }
  }
  odometry->finish(run.t_end, sink);
  run.steps = odometry->steps();
  run.summary.fixes = odometry->fixes();
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
  StepWriterThread steps(writer);
  const OdometryRun run = run_odometry(
      config, config_path, log, options,
      [&](const OdometryStep& step) {
        steps.write(step);
        // About once a second: on this thread.
        if (calibration) calibration->write(step);
      },
      progress);
  steps.finish();
  writer.commit();
  if (calibration) calibration->commit();
  return run;
}

}  // namespace moa::io
