#include "moa/runs/run_loop.hpp"

#include <fmt/core.h>

#include "moa/core/wheels.hpp"
#include "moa/formats/error.hpp"
#include "moa/runs/odometry_run.hpp"

namespace moa::io {

double row_time(const InputRow& row) {
  return std::visit([](const auto& r) { return static_cast<double>(r.t); }, row);
}

OdometryRun run_loop(const RobotConfig& config, const std::string& config_path,
                     const OdometryOptions& options, RunSource& source,
                     const std::string& source_name, const RunCallbacks& callbacks) {
  OdometryRun run;
  run.t0 = source.start_time();
  run.t_end = run.t0;
  const auto odometry = make_odometry(config, config_path, run.t0, options);

  const auto warn = [&](std::string text) {
    if (callbacks.warn) callbacks.warn(text);
    run.summary.warnings.push_back(std::move(text));
  };
  // A sensor whose self-calibration ran away is excluded as 'calibration'
  // while beyond the bounds: said once per sensor.
  SensorMask runaway_seen = 0;
  // A reset of a sensor's calibration (SelfCalibration: a test over time
  // that alarms at most once an hour of driving by chance): said each time.
  std::array<long, kMaxSensors> resets_seen{};
  const auto sink = [&](const OdometryStep& step) {
    if (step.calibration_resets != nullptr) {
      for (int i = 0; i < config.array.size(); ++i) {
        const auto u = static_cast<std::size_t>(i);
        if ((*step.calibration_resets)[u] <= resets_seen[u]) continue;
        resets_seen[u] = (*step.calibration_resets)[u];
        warn(fmt::format(
            "sensor '{}': its self-calibration was reset at t = {:.3f} s (its blocks failed the "
            "gate at more than the false-alarm rate {} and agree with another calibration): "
            "learnt again from there",
            config.names[u], step.t(), options.self_calibration.gross_alpha));
      }
    }
    if (step.calibration != nullptr) {
      for (int i = 0; i < config.array.size(); ++i) {
        if (step.estimate.excluded[static_cast<std::size_t>(i)] != Exclusion::kCalibration ||
            contains(runaway_seen, i)) {
          continue;
        }
        runaway_seen |= SensorMask{1} << i;
        const auto& c = (*step.calibration_filter)[static_cast<std::size_t>(i)];
        warn(fmt::format(
            "sensor '{}': its self-calibration ran away (scale {:.3f}, {:.3f}, yaw offset {:.3f} "
            "rad at t = {:.3f} s; beyond a sound sensor's tolerance {} and {} rad at false-alarm "
            "rate {}): excluded as 'calibration' while beyond",
            config.names[static_cast<std::size_t>(i)], c.scale_x, c.scale_y, c.yaw_offset, step.t(),
            options.self_calibration.runaway_scale, options.self_calibration.runaway_yaw,
            options.self_calibration.runaway_alpha));
      }
    }
    run.summary.add(step, config.array.size());
    if (callbacks.on_step) callbacks.on_step(step);
  };
  // The refusal's words; for too much silence, with its numbers.
  const auto detail = [&](double t, OdometryError e) -> std::string {
    if (e == OdometryError::kWheelsFull || e == OdometryError::kImuFull) {
      // The rows of one epoch and those fed ahead of the mice must fit the
      // stream's fixed ring (no heap).
      return fmt::format(
          "{} (at most {} rows are kept ahead of the mice rows; an epoch is {} s at --rate {} "
          "Hz: a higher --rate needs fewer, and a log's streams must cover the same times)",
          describe(e), IntervalAverager<3>::kCapacity, 1.0 / options.rate, options.rate);
    }
    if (e != OdometryError::kRow) return describe(e);
    const RowError r = odometry->row_error();
    if (r != RowError::kTooMuchSilence) return describe(r);
    const Synchroniser& sync = odometry->synchroniser();
    return fmt::format(
        "the sensors have been silent for {:.2f} s in total by this row (the time between rows "
        "beyond --max-row-interval {} s), more than the {:.2f} s allowed: --max-gap {} s plus "
        "{} s (one epoch) for each of the {} rows before it; a log of sparse rows would write an "
        "epoch every {} s over every gap. Raise --max-gap if the log is meant so",
        sync.silence_at(t), sync.options().max_row_interval, sync.silence_allowed(),
        sync.options().max_gap, sync.options().period, sync.rows(), sync.options().period);
  };
  const auto fail = [&](double t, OdometryError e) {
    throw Error(fmt::format("{}: row at t = {} s: {}", source.where(), t, detail(t, e)));
  };

  while (const InputRow* input = source.next()) {
    if (const auto* row = std::get_if<SensorRow>(input)) {
      if (const auto e = odometry->push(*row, sink)) {
        // Too much silence is not one bad row: every later row would be
        // refused too, so it ends the run as it ends `moa odometry`.
        const bool refused =
            (e == OdometryError::kRow && odometry->row_error() != RowError::kTooMuchSilence) ||
            e == OdometryError::kImpossibleCounts;
        if (!refused || !callbacks.on_refused) fail(row->t, *e);
        callbacks.on_refused(*row, detail(row->t, *e));
        continue;
      }
      if (callbacks.on_row) callbacks.on_row(*input);
      run.t_end = row->t;
      ++run.rows;
      if (row->sensor >= 0 && row->sensor < kMaxSensors) {
        ++run.rows_per_sensor[static_cast<std::size_t>(row->sensor)];
      }
      if (callbacks.progress && (run.rows & 0xfff) == 0) callbacks.progress(run.rows, row->t);
    } else {
      // A stream's row: recorded once the pipeline has taken it. A burst a
      // live run cannot hold (the stream's ring of rows ahead of the mice
      // full) is skipped there, not the run's end.
      std::optional<OdometryError> e;
      if (const auto* wheel = std::get_if<WheelRow>(input)) {
        e = odometry->push_wheels(wheel->t, wheel->twist, sink);
      } else if (const auto* imu = std::get_if<ImuRow>(input)) {
        e = odometry->push_gyro(imu->t, imu->gz, sink, imu->faults != 0);
      } else {
        e = odometry->push_fix(std::get<CameraFix>(*input));
      }
      const double t = row_time(*input);
      if (e) {
        const bool full = e == OdometryError::kWheelsFull || e == OdometryError::kImuFull ||
                          e == OdometryError::kFixesFull;
        if (!full || !callbacks.on_stream_full) fail(t, *e);
        callbacks.on_stream_full(*input, detail(t, *e));
        continue;
      }
      if (callbacks.on_row) callbacks.on_row(*input);
      if (std::holds_alternative<WheelRow>(*input)) {
        ++run.wheel_rows;
      } else if (std::holds_alternative<ImuRow>(*input)) {
        ++run.imu_rows;
      } else {
        ++run.fix_rows;
      }
    }
  }
  // Sensors of the config that never reported: a silent sensor reads as
  // still, which least squares averages in (metres off on a moving robot).
  for (std::size_t i = 0; i < config.names.size(); ++i) {
    if (run.rows_per_sensor[i] != 0 || !contains(options.sensors, static_cast<int>(i))) continue;
    const std::string& name = config.names[i];
    if (options.estimator == EstimatorKind::kLs || options.estimator == EstimatorKind::kOracle) {
      throw Error(fmt::format(
          "{}: sensor '{}' of {} never reports: {} would take it as still; leave it out of the "
          "selected sensors or use a robust estimator (consensus, sekimori)",
          source_name, name, config_path, to_name(options.estimator)));
    }
    if (options.estimator != EstimatorKind::kWheels) {
      warn(fmt::format(
          "{}: sensor '{}' of {} never reports: the {} estimator saw it as a still sensor",
          source_name, name, config_path, to_name(options.estimator)));
    }
  }
  odometry->finish(run.t_end, sink);
  run.steps = odometry->steps();
  run.summary.fixes = odometry->fixes();
  return run;
}

}  // namespace moa::io
