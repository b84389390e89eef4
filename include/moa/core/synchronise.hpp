// From per-sensor rows at arbitrary times to array samples at common epochs.
//
// Epoch k covers (t0 + k P, t0 + (k+1) P], P the period (default 10 ms).
// A row of sensor i at time t carries the counts accumulated over its own
// interval (a, t], a = max(previous row of i (or t0), t - max_row_interval):
// the counts are spread over the epochs in proportion to overlap, so rows
// already on the epoch grid map onto exactly one epoch each and are used as
// they are. A row with an empty interval (the first row at t0, or a repeat
// of the same time) goes whole into the epoch that contains t. No rows means
// no motion: epochs nobody reported in are emitted with zero counts.
//
// Why max_row_interval: a sensor that reports only while moving (a USB
// mouse) has rows far apart after a pause; its first row then covers the
// last report period, not the whole pause.
//
// Streaming: an epoch is final once no later row can overlap it, i.e. its
// end is <= max(t_row - max_row_interval, min_i last_t_i). Pending epochs
// live in a fixed ring of kMaxPendingEpochs (no heap): max_row_interval
// may span at most kMaxPendingEpochs - 3 periods (SynchroniserOptions::
// validate says so).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>

#include "moa/core/array.hpp"
#include "moa/core/options_check.hpp"
#include "moa/core/ring.hpp"

namespace moa {

/// One sensor's report: counts in its own frame over the interval ending at t.
struct SensorRow {
  double t = 0.0;  ///< s
  int sensor = 0;  ///< index in the SensorArray
  Vec2 counts{0.0, 0.0};
  std::optional<std::uint8_t> squal;
  std::uint8_t flags = 0;
  std::uint8_t faults = 0;  ///< simulated fault bits (faults.csv), for the oracle
};

/// s, the largest |t| any row may carry: unix times (1.7e9 s in 2024) up to
/// the year 2096. A double resolves 4e9 s to 4.8e-7 s (2^-21 s), 0.005 % of
/// a 10 ms epoch and 0.5 % of the shortest (0.1 ms, 10 kHz), so epoch
/// boundaries t0 + k period stay exact to that; beyond ~1e15 s it no longer
/// resolves a millisecond and epochs were counted wrong (or never ended).
inline constexpr double kMaxTime = 4e9;
/// s, the longest span from a log file's first time to its last that its
/// reader accepts (one day: at 100 Hz, 8.64e6 epochs). Live runs have none:
/// their rows come at the pace of real time.
inline constexpr double kMaxSpan = 86400.0;

enum class RowError {
  kTimeNotFinite,
  kTimeOutOfRange,   ///< |t| > kMaxTime
  kTimeBeforeStart,  ///< t < t0
  kTimeBackwards,    ///< t earlier than the previous row's
  kUnknownSensor,    ///< index outside the array
  kCountsNotFinite,
  kTimeJump,  ///< t later than the previous row's by more than max_gap
  /// the sensors' silences so far sum to more than max_gap plus one period
  /// per row read (Synchroniser::silence_allowed)
  kTooMuchSilence,
};
const char* describe(RowError error);

/// The checks every consumer of rows makes: a finite time not before t0 nor
/// before the previous row's (`last_row_t`) nor more than `max_gap` (s)
/// after it, |t| <= kMaxTime, a sensor index below n_sensors, finite counts.
inline std::optional<RowError> check_row(const SensorRow& row, int n_sensors, double t0,
                                         double last_row_t,
                                         double max_gap = std::numeric_limits<double>::infinity()) {
  if (!std::isfinite(row.t)) return RowError::kTimeNotFinite;
  if (std::abs(row.t) > kMaxTime) return RowError::kTimeOutOfRange;
  if (row.t < t0) return RowError::kTimeBeforeStart;
  if (row.t < last_row_t) return RowError::kTimeBackwards;
  if (row.t - last_row_t > max_gap) return RowError::kTimeJump;
  if (row.sensor < 0 || row.sensor >= n_sensors) return RowError::kUnknownSensor;
  if (!row.counts.allFinite()) return RowError::kCountsNotFinite;
  return std::nullopt;
}

/// Epochs that can be pending at once (each an ArraySample, ~300 bytes).
inline constexpr std::size_t kMaxPendingEpochs = 64;

struct SynchroniserOptions {
  double period = 0.01;            ///< s, epoch length (100 Hz)
  double max_row_interval = 0.05;  ///< s, longest interval one row can cover
  /// s, longest silence of all sensors accepted. A gap is no motion and is
  /// emitted epoch by epoch, so a log glued from recordings made days apart
  /// would emit (and a writer write) millions of still epochs: refused.
  /// It also bounds the silences summed over the stream (see
  /// Synchroniser::silence_allowed).
  double max_gap = 3600.0;
  /// s per sensor, a row's t minus the true end of its interval
  /// (SensorMount::latency): sensor i's row at t covers an interval ending at
  /// t - latency[i], clamped to t0. Rows are still fed in the order of their
  /// t; the epochs wait for max(latency) - min(latency) more.
  std::array<double, kMaxSensors> latency{};

  /// nullopt when usable, else the first field out of its bounds
  /// (options_check.hpp): period and max_row_interval positive and finite,
  /// max_row_interval plus the latencies' spread at most
  /// kMaxPendingEpochs - 3 periods, max_gap positive (infinite: no limit),
  /// latencies finite.
  OptionCheck validate() const;
};

class Synchroniser {
 public:
  /// n sensors (at most kMaxSensors), first epoch starting at t0 (the log's
  /// first time); options.validate() must have passed.
  Synchroniser(int n_sensors, double t0, SynchroniserOptions options = {});

  /// Adds a row and calls sink(const ArraySample&) for every epoch that
  /// became final, in time order. Returns the error instead when the row is
  /// invalid (nothing is changed then).
  template <class Sink>
  std::optional<RowError> push(const SensorRow& row, Sink&& sink) {
    if (auto error = check_row(row, n_, t0_, last_row_t_, options_.max_gap)) return error;
    const double silence = silence_at(row.t);
    if (silence > silence_allowed()) return RowError::kTooMuchSilence;
    silence_ = silence;
    ++rows_;
    // Epochs that end before this row's interval can start are final now;
    // emitting them first keeps the pending span within the ring.
    emit_until(final_time(row.t), sink);
    add(row);
    emit_until(final_time(row.t), sink);
    return std::nullopt;
  }

  /// Time has reached t on another stream fed in the same time order (a
  /// wheel row, a clock): no later row can reach back before
  /// t - max_row_interval, so the epochs that end by then are final.
  template <class Sink>
  void advance(double t, Sink&& sink) {
    if (std::isfinite(t) && t >= last_row_t_) {
      emit_until(t - latest_ - options_.max_row_interval, sink);
    }
  }

  /// s, the true end of a row's interval: t - latency of its sensor, not
  /// before t0.
  double end_of_row(const SensorRow& row) const {
    return std::max(row.t - options_.latency[static_cast<std::size_t>(row.sensor)], t0_);
  }

  /// Emits every remaining epoch up to t_end (the last epoch is cut at
  /// t_end). Call once at the end of the stream.
  template <class Sink>
  void finish(double t_end, Sink&& sink) {
    while (start_of(next_) < t_end) {
      ArraySample& s = slot(next_);
      if (end_of(next_) > t_end) {
        s.dt = static_cast<real>(t_end - start_of(next_));
        s.t = t_end;
      }
      sink(static_cast<const ArraySample&>(s));
      pop();
    }
  }

  double t0() const { return t0_; }
  /// s, the silences so far: for each row, the time since the previous row
  /// (of any sensor) beyond max_row_interval, which no row covers.
  double silence() const { return silence_; }
  /// s, silence() with a row at t added.
  double silence_at(double t) const {
    return silence_ + std::max<double>(0.0, t - last_row_t_ - options_.max_row_interval);
  }
  /// Rows accepted so far.
  std::int64_t rows() const { return rows_; }
  /// s, the silence the stream may have reached: max_gap plus one period per
  /// row accepted. Each emitted epoch either holds a row's counts (a row
  /// spreads over at most max_row_interval / period + 2 epochs) or is
  /// silent, so a stream of N rows emits at most
  ///   max_gap / period + N (max_row_interval / period + 3)
  /// epochs (360 000 + 8 N with the defaults): a few sparse rows can no
  /// longer make millions of still epochs, while a parked robot's hour, or
  /// a pause for every few rows of a long run, is still accepted.
  double silence_allowed() const {
    return options_.max_gap + static_cast<double>(rows_) * options_.period;
  }
  /// End of sensor i's last row (t0 before its first).
  double last_time(int sensor) const { return last_t_[static_cast<std::size_t>(sensor)]; }
  const SynchroniserOptions& options() const { return options_; }

 private:
  void add(const SensorRow& row);
  double final_time(double t_row) const;
  double start_of(std::int64_t k) const { return t0_ + static_cast<double>(k) * options_.period; }
  double end_of(std::int64_t k) const { return start_of(k + 1); }
  /// The pending epoch k >= next_, created empty (with those before it) if new.
  ArraySample& slot(std::int64_t k);
  /// Epoch next_ was emitted: drop it.
  void pop() {
    if (!ring_.empty()) ring_.pop_front();
    ++next_;
  }
  /// Index of the epoch whose interval (start, end] contains t (0 for t0).
  std::int64_t epoch_of(double t) const;

  template <class Sink>
  void emit_until(double t_final, Sink& sink) {
    while (end_of(next_) <= t_final) {
      sink(static_cast<const ArraySample&>(slot(next_)));
      pop();
    }
  }

  int n_;
  double t0_;
  SynchroniserOptions options_;
  FixedRing<ArraySample, kMaxPendingEpochs> ring_;  // epochs next_ .. next_ + size - 1
  std::array<double, kMaxSensors> last_t_{};        // per sensor, end of its previous row
  std::int64_t next_ = 0;                           // first epoch not yet emitted
  double last_row_t_;
  double latest_ = 0.0;    // s, the largest latency of the n sensors
  double silence_ = 0.0;   // s, see silence()
  std::int64_t rows_ = 0;  // rows accepted
};

}  // namespace moa
