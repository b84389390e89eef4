#include "moa/runs/odometry_run.hpp"

#include "moa/formats/diagnostics_csv.hpp"
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
#include "moa/runs/option_error.hpp"
#include "moa/runs/run_loop.hpp"

namespace moa::io {
namespace fs = std::filesystem;

namespace {
// OdometryOptions::validate()'s refusal, "path: what". The options that
// every front end gives by the field's own name (rate, max_row_interval,
// max_gap) are named as the front end names them (OptionError).
[[noreturn]] void refuse(const InvalidOption& e) {
  const std::string_view text = e.view();
  for (const std::string_view field : {"rate", "max_row_interval", "max_gap"}) {
    if (text.size() > field.size() && text.substr(0, field.size()) == field &&
        text[field.size()] == ':') {
      throw OptionError(fmt::format("invalid option: {{{}}}{}", field,
                                    OptionError::literal(text.substr(field.size()))));
    }
  }
  throw Error(fmt::format("invalid option: {}", text));
}
}  // namespace

OdometryOptions resolve_odometry_options(OdometryOptions o, std::string_view estimator,
                                         const std::vector<std::string>& sensors, bool no_wheels,
                                         const RobotConfig& config,
                                         const std::string& config_path) {
  const auto kind = from_name<EstimatorKind>(estimator);
  if (!kind) {
    throw OptionError(fmt::format("{{estimator}}: unknown estimator '{}'",
                                  OptionError::literal(printable(estimator))));
  }
  o.estimator = *kind;
  o.use_wheels = !no_wheels;
  if (o.self_calibration.enabled &&
      (o.estimator == EstimatorKind::kLs || o.estimator == EstimatorKind::kSekimori ||
       o.estimator == EstimatorKind::kOracle)) {
    // The core refuses it too (OdometryOptions::validate); here with the flags.
    throw OptionError(fmt::format(
        "{{self_calibrate}} needs {{estimator}} consensus, not {}: ls and sekimori use every "
        "sensor, so one whose calibration runs away could not be left out; oracle selects by "
        "the simulator's fault labels, not by tested hypotheses",
        estimator));
  }
  if (o.estimator == EstimatorKind::kWheels && no_wheels) {
    throw OptionError("{estimator} wheels and {no_wheels} exclude each other");
  }
  if (o.self_calibration.enabled && o.self_calibration.gauge == SelfCalibrationGauge::kWheels &&
      no_wheels) {
    throw OptionError("{self_calibration.gauge} wheels and {no_wheels} exclude each other");
  }
  if (!sensors.empty()) {
    o.sensors = 0;
    for (const auto& name : sensors) {
      const auto i = config.index_of(name);
      if (!i) {
        std::string names;
        for (const auto& n : config.names) names += (names.empty() ? "" : ", ") + n;
        throw OptionError(fmt::format(
            "{{sensors}}: unknown sensor '{}' ({} has {})", OptionError::literal(printable(name)),
            OptionError::literal(config_path), OptionError::literal(names)));
      }
      if (contains(o.sensors, *i)) {
        throw OptionError(fmt::format("{{sensors}}: sensor '{}' named twice",
                                      OptionError::literal(printable(name))));
      }
      o.sensors |= SensorMask{1} << *i;
    }
  }
  if (const auto e = o.validate()) refuse(*e);
  return o;
}

std::vector<fs::path> LogFiles::files() const {
  std::vector<fs::path> out{mice};
  for (const auto& f : {wheels, imu, camera, truth, faults}) {
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
    const fs::path part = fs::path(files.mice) += ".part";
    if (!fs::exists(files.mice, ec) && fs::is_regular_file(part, ec)) {
      // MiceWriter's journal (moa live --record) of a run that was killed.
      throw Error(fmt::format(
          "{}: no such file, but {} is there: the recording was interrupted (killed before it "
          "ended); its rows up to the last flush are in that file. To recover them: mv {} {} (if "
          "its last line was cut, delete that line)",
          files.mice.string(), part.string(), part.string(), files.mice.string()));
    }
    const fs::file_status status = fs::status(files.mice, ec);
    if (fs::is_fifo(status) || fs::is_character_file(status) || fs::is_block_file(status) ||
        fs::is_socket(status) || fs::is_directory(status)) {
      throw Error(
          fmt::format("{}: not a regular file (a {}): a log is read from files; copy it "
                      "to one first",
                      files.mice.string(),
                      fs::is_fifo(status)        ? "named pipe"
                      : fs::is_directory(status) ? "directory"
                                                 : "device or socket"));
    }
    throw IoError(
        fmt::format("{}: no such file (a log directory holds mice.csv)", files.mice.string()));
  }
  const auto optional = [&](const char* name) -> std::optional<fs::path> {
    const fs::path p = files.dir / name;
    if (fs::exists(p, ec)) return p;
    return std::nullopt;
  };
  files.wheels = optional("wheels.csv");
  files.imu = optional("imu.csv");
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
  if (config.imu) options.consensus.gyro = *config.imu;
  // --camera-latency overrides the config's; the wheels' has no flag.
  if (!options.camera_latency) options.camera_latency = config.camera_latency.value_or(0.0);
  if (config.wheels_latency) options.wheels_latency = *config.wheels_latency;
  // A log's imu.csv is used with the defaults of GyroOptions when the config
  // has no imu: block; one sensor then takes its rotation from it.
  options.consensus.gyro_fed = options.use_imu;
  if (const auto e = options.validate()) refuse(*e);
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
  /// After mice.csv's last row: faults.csv must end there too.
  void finish() {
    if (csv_.next()) {
      csv_.fail("has rows past mice.csv's end (one row per mice.csv row: another log's?)");
    }
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
      if (faults_ != nullptr) faults_->finish();
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

/// The files of a log as a run's source: mice.csv parsed on a thread of its
/// own (with faults.csv's twin rows for the oracle); before each mice row,
/// the camera fixes, then the wheel rows, then the gyro rows up to its time;
/// after the last, those up to the last row's time (the stream ends with its
/// mice).
class LogRunSource final : public RunSource {
 public:
  LogRunSource(MiceReader& mice, FaultsReader* faults, WheelsReader* wheels, ImuReader* imu,
               CameraReader* camera, const LogFiles& log)
      : mice_(mice),
        wheels_(wheels),
        imu_(imu),
        camera_(camera),
        log_(log),
        wheel_(wheels ? wheels->next() : std::nullopt),
        gyro_(imu ? imu->next() : std::nullopt),
        fix_(camera ? camera->next() : std::nullopt),
        t_last_(mice.start_time()),
        parsed_(mice, faults) {}

  double start_time() override { return mice_.start_time(); }

  const InputRow* next() override {
    if (pending_ == nullptr && !ended_) {
      pending_ = parsed_.next();
      if (pending_ == nullptr) {
        ended_ = true;
        parsed_.join();
      }
    }
    const double limit = ended_ ? t_last_ : pending_->row.t;
    if (fix_ && fix_->t <= limit) {
      row_ = CameraFix{fix_->t, fix_->position, fix_->theta, fix_->sigma};
      from_ = From::kCamera;
      fix_ = camera_->next();
      return &row_;
    }
    if (wheel_ && wheel_->t <= limit) {
      row_ = *wheel_;
      from_ = From::kWheels;
      wheel_ = wheels_->next();
      return &row_;
    }
    if (gyro_ && gyro_->t <= limit) {
      row_ = *gyro_;
      from_ = From::kImu;
      gyro_ = imu_->next();
      return &row_;
    }
    if (ended_) return nullptr;
    row_ = pending_->row;
    from_ = From::kMice;
    line_ = pending_->line;
    t_last_ = pending_->row.t;
    pending_ = nullptr;
    return &row_;
  }

  std::string where() const override {
    switch (from_) {
      case From::kMice:
        return fmt::format("{}:{}", log_.mice.string(), line_);
      case From::kWheels:
        return log_.wheels->string();
      case From::kImu:
        return log_.imu->string();
      case From::kCamera:
        return log_.camera->string();
    }
    return {};
  }

 private:
  enum class From : std::uint8_t { kMice, kWheels, kImu, kCamera };
  MiceReader& mice_;
  WheelsReader* wheels_;
  ImuReader* imu_;
  CameraReader* camera_;
  const LogFiles& log_;
  std::optional<WheelRow> wheel_;        ///< next wheel row, not yet handed out
  std::optional<ImuRow> gyro_;           ///< next gyro row, not yet handed out
  std::optional<CameraRow> fix_;         ///< next fix, not yet handed out
  double t_last_;                        ///< s, the last mice row handed out (start: t0)
  const MiceRecord* pending_ = nullptr;  ///< next mice row, not yet handed out
  bool ended_ = false;                   ///< mice.csv read to its end
  InputRow row_;
  From from_ = From::kMice;
  std::size_t line_ = 0;
  MiceReaderThread parsed_;  ///< last: its thread starts with the rest built
};

}  // namespace

std::unique_ptr<ImuReader> open_log_imu(const RobotConfig& config, const LogFiles& log,
                                        const OdometryOptions& options, bool other_gyro) {
  // The gyro goes to the consensus and the oracle (least squares and Sekimori
  // & Miyazaki stay as their papers define them).
  std::unique_ptr<ImuReader> imu;
  if (options.use_imu && log.imu &&
      (options.estimator == EstimatorKind::kConsensus ||
       options.estimator == EstimatorKind::kOracle)) {
    imu = std::make_unique<ImuReader>(*log.imu);
  }
  // One sensor: the config's only one, or the only one --sensors selects
  // (without a gyro the consensus would take the wheels in every epoch).
  const bool one = count_sensors(options.sensors & all_sensors(config.array.size())) == 1;
  if (one && options.estimator != EstimatorKind::kWheels) {
    // Another gyro (a live run's streams) may stand in for a missing imu.csv,
    // not for a pipeline that takes none.
    const bool takes_gyro = options.use_imu && options.estimator == EstimatorKind::kConsensus;
    if (!imu && (!takes_gyro || !other_gyro)) {
      throw Error(fmt::format("{}: one sensor{} needs a gyro for its rotation: {}",
                              log.mice.string(),
                              config.array.size() > 1 ? " (the one --sensors selects)" : "",
                              !options.use_imu ? "--no-imu given"
                              : !log.imu       ? "no imu.csv in " + log.dir.string()
                                               : "the estimator is not consensus"));
    }
    // Two rows at least: the first only opens the gyro's first interval.
    if (imu && !other_gyro) {
      ImuReader peek(*log.imu);
      int rows = 0;
      while (rows < 2 && peek.next()) ++rows;
      if (rows < 2) {
        throw Error(
            fmt::format("{}: one sensor needs a gyro for its rotation: {} has {} data row{} "
                        "(the first only opens an interval)",
                        log.mice.string(), log.imu->string(), rows, rows == 1 ? "" : "s"));
      }
    }
  }
  return imu;
}

LogStreams open_log_streams(const RobotConfig& config, const LogFiles& log,
                            const OdometryOptions& options, bool other_streams) {
  LogStreams s;
  if (options.estimator == EstimatorKind::kWheels && !log.wheels && !other_streams) {
    // Else every epoch would be a hold (the pose never moves).
    throw Error(fmt::format("{}: the wheels estimator needs wheels.csv in the log",
                            (log.dir / "wheels.csv").string()));
  }
  if (options.use_wheels && log.wheels) s.wheels = std::make_unique<WheelsReader>(*log.wheels);
  s.imu = open_log_imu(config, log, options, other_streams);
  if (options.fuse_camera) {
    if (log.camera) {
      s.camera = std::make_unique<CameraReader>(*log.camera);
    } else if (!other_streams) {
      throw Error(fmt::format("{}: camera fusion needs camera.csv in the log",
                              (log.dir / "camera.csv").string()));
    }
  }
  return s;
}

OdometryRun run_odometry(const RobotConfig& config, const std::string& config_path,
                         const LogFiles& log, const OdometryOptions& options,
                         const StepCallback& on_step, const ProgressCallback& progress) {
  MiceReader mice(log.mice, config);
  const LogStreams streams = open_log_streams(config, log, options);
  std::unique_ptr<FaultsReader> faults;
  if (options.estimator == EstimatorKind::kOracle) {
    if (!log.faults) {
      throw Error(fmt::format("{}: the oracle needs the simulator's faults.csv",
                              (log.dir / "faults.csv").string()));
    }
    faults = std::make_unique<FaultsReader>(*log.faults, config);
  }
  LogRunSource source(mice, faults.get(), streams.wheels.get(), streams.imu.get(),
                      streams.camera.get(), log);
  RunCallbacks callbacks;
  callbacks.on_step = on_step;
  callbacks.progress = progress;
  return run_loop(config, config_path, options, source, log.mice.string(), callbacks);
}

OdometryRun write_odometry(const RobotConfig& config, const std::string& config_path,
                           const LogFiles& log, const OdometryOptions& options, const fs::path& out,
                           const ProgressCallback& progress, const fs::path& calibration_out,
                           const fs::path& diagnostics_out) {
  std::unique_ptr<DiagnosticsCsvWriter> diagnostics;
  if (!diagnostics_out.empty()) {
    diagnostics = std::make_unique<DiagnosticsCsvWriter>(
        diagnostics_out, config.names, options.sensors & all_sensors(config.array.size()));
  }
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
        if (diagnostics) diagnostics->write(step);
      },
      progress);
  steps.finish();
  writer.commit();
  if (calibration) calibration->commit();
  if (diagnostics) diagnostics->commit();
  return run;
}

}  // namespace moa::io
