#include "moa/core/synchronise.hpp"

#include <algorithm>
#include <cmath>

namespace moa {

const char* describe(RowError error) {
  switch (error) {
    case RowError::kTimeNotFinite:
      return "time is not a finite number";
    case RowError::kTimeOutOfRange:
      return "time is outside -4e9..4e9 s (kMaxTime: beyond, a double does not resolve the epoch "
             "step)";
    case RowError::kTimeBeforeStart:
      return "time is before the start of the log";
    case RowError::kTimeBackwards:
      return "time goes backwards";
    case RowError::kUnknownSensor:
      return "unknown sensor";
    case RowError::kCountsNotFinite:
      return "counts are not finite numbers";
    case RowError::kTimeJump:
      return "time jumps forward by more than the longest gap allowed (--max-gap): recordings "
             "made at different times?";
    case RowError::kTooMuchSilence:
      return "the sensors' silences add up to more than --max-gap plus one epoch per row: sparse "
             "rows would write an epoch per period over every gap (raise --max-gap if the log is "
             "meant so)";
  }
  return "invalid row";
}

OptionCheck SynchroniserOptions::validate() const {
  constexpr auto kSpan = static_cast<long long>(kMaxPendingEpochs - 3);  // periods one row covers
  InvalidOption span;  // the bound's name: "61 periods"
  span.append_integer(kSpan);
  span.append(" periods");
  OptionsCheck c;
  double earliest = 0.0, latest = 0.0;
  for (const double l : latency) {
    c.require(std::isfinite(l), "latency", "finite", l);
    earliest = std::min(earliest, l);
    latest = std::max(latest, l);
  }
  c.positive("period", period)
      .positive("max_row_interval", max_row_interval)
      .at_most_named("max_row_interval", max_row_interval, span.message(),
                     static_cast<double>(kSpan) * period)
      .at_most_named("max_row_interval + latency spread", max_row_interval + latest - earliest,
                     span.message(), static_cast<double>(kSpan) * period);
  c.positive_or_infinite("max_gap", max_gap);
  return c.result();
}

Synchroniser::Synchroniser(int n_sensors, double t0, SynchroniserOptions options)
    : n_(std::min(n_sensors, kMaxSensors)), t0_(t0), options_(options), last_row_t_(t0) {
  last_t_.fill(t0);
  // Unused entries (sensors beyond n) take no part.
  for (int i = 0; i < n_; ++i) {
    const double l = options_.latency[static_cast<std::size_t>(i)];
    latest_ = i == 0 ? l : std::max(latest_, l);
  }
}

ArraySample& Synchroniser::slot(std::int64_t k) {
  const auto index = static_cast<std::size_t>(k - next_);
  while (ring_.size() <= index) {
    const std::int64_t j = next_ + static_cast<std::int64_t>(ring_.size());
    ArraySample& s = ring_.push_back();
    s.t = end_of(j);
    s.dt = static_cast<real>(options_.period);
    s.size = n_;
    for (int i = 0; i < n_; ++i) {
      const auto u = static_cast<std::size_t>(i);
      s.counts[u].setZero();
      s.squal[u] = 255;
      s.flags[u] = 0;
      s.faults[u] = 0;
    }
  }
  return ring_[index];
}

std::int64_t Synchroniser::epoch_of(double t) const {
  const double q = (t - t0_) / options_.period;
  // std::ceil(q) without the call (a library call on baseline x86-64): the
  // truncation, one up when below q; exact while q fits an int64.
  std::int64_t c = 0;
  if (std::abs(q) < 0x1p62) {
    c = static_cast<std::int64_t>(q);
    if (static_cast<double>(c) < q) ++c;
  } else {
    c = static_cast<std::int64_t>(std::ceil(q));
  }
  return std::max<std::int64_t>(c - 1, 0);
}

void Synchroniser::add(const SensorRow& row) {
  const auto i = static_cast<std::size_t>(row.sensor);
  const double b = end_of_row(row);
  const double a = std::max(last_t_[i], b - options_.max_row_interval);
  last_t_[i] = b;
  last_row_t_ = row.t;
  const auto deposit = [&](std::int64_t k, double fraction) {
    // Rows are never older than the first pending epoch (see final_time()).
    ArraySample& s = slot(std::max(k, next_));
    s.counts[i] += fraction * row.counts;
    if (row.squal) s.squal[i] = std::min(s.squal[i], *row.squal);
    s.flags[i] |= row.flags;
    s.faults[i] |= row.faults;
  };
  if (!(b > a)) {
    deposit(epoch_of(b), 1.0);
    return;
  }
  const double length = b - a;
  for (std::int64_t k = epoch_of(a); start_of(k) < b; ++k) {
    const double overlap = std::min(b, end_of(k)) - std::max(a, start_of(k));
    // A row on the epoch grid lies whole in one epoch: x / x is 1 exactly,
    // without the division.
    if (overlap > 0.0) deposit(k, overlap == length ? 1.0 : overlap / length);
  }
}

double Synchroniser::final_time(double t_row) const {
  if (n_ == 0) return t_row;
  // The first of the smallest, as std::min_element, without its branches.
  double oldest = last_t_[0];
  for (int i = 1; i < n_; ++i) oldest = std::min(oldest, last_t_[static_cast<std::size_t>(i)]);
  // A later row, fed at t >= t_row, ends at t - latency >= t_row - latest_.
  return std::max(t_row - latest_ - options_.max_row_interval, oldest);
}

}  // namespace moa
