#include "moa/sources/otos_reader.hpp"

#include <fmt/core.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <deque>
#include <set>
#include <thread>

#include "moa/core/array.hpp"
#include "moa/formats/error.hpp"

namespace moa::io {

std::string OtosOptions::validate() const {
  if (!(rate >= kMinRate && rate <= otos::kLoopRate)) {
    return fmt::format("rate: must be {:g} to {:.4g} Hz (the unit's loop), is {}", kMinRate,
                       otos::kLoopRate, rate);
  }
  if (start.imu_samples < 1 || start.imu_samples > 255) {
    return fmt::format("start.imu_samples: must be 1 to 255, is {}", start.imu_samples);
  }
  if (!(silent_after > 0.0 && std::isfinite(silent_after))) {
    return fmt::format("silent_after: must be > 0 s and finite, is {}", silent_after);
  }
  if (!(retry_period > 0.0 && std::isfinite(retry_period))) {
    return fmt::format("retry_period: must be > 0 s and finite, is {}", retry_period);
  }
  if (!(max_acceleration > 0.0)) {
    return fmt::format("max_acceleration: must be > 0, is {}", max_acceleration);
  }
  if (!(max_angular_acceleration > 0.0)) {
    return fmt::format("max_angular_acceleration: must be > 0, is {}", max_angular_acceleration);
  }
  return {};
}

Vec2 VelocityCounts::add(double t, const Vec2& w) {
  if (!open_) {
    open_ = true;
    t_ = t;
    w_ = w;
    remainder_.setZero();
    return Vec2::Zero();
  }
  // Trapezoid of the velocity over (t_, t], in counts, plus what the last
  // rounding left.
  const Vec2 exact = k_ * 0.5 * (w_ + w) * (t - t_) + remainder_;
  const Vec2 whole(std::round(exact.x()), std::round(exact.y()));
  remainder_ = exact - whole;
  t_ = t;
  w_ = w;
  return whole;
}

OtosClock monotonic_clock() {
  return {[] {
            timespec ts{};
            clock_gettime(CLOCK_MONOTONIC, &ts);
            return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
          },
          [](double s) {
            if (s > 0.0) std::this_thread::sleep_for(std::chrono::duration<double>(s));
          }};
}

namespace {

// What is said once per unit.
enum Said : unsigned {
  kSaidTracking = 1u << 0,
  kSaidOpticalFault = 1u << 1,
  kSaidTilt = 1u << 2,
  kSaidImuFault = 1u << 3,
  kSaidCorrupt = 1u << 4,
  kSaidImplausible = 1u << 5,
  kSaidSaturated = 1u << 6,
};

struct Unit {
  OtosLink link;
  VelocityCounts counts{1.0};
  OtosReader::UnitStats stats;
  unsigned said = 0;
  double last_good = 0.0;  ///< s (row clock) of the last good read
  double last_try = 0.0;   ///< s, the last start tried while silent
  double silent_since = 0.0;
  int last_error = 0;
  // The previous read, dropped or not, for the plausibility of the next.
  bool has_previous = false;
  double previous_t = 0.0;
  Vec2 previous_velocity{0.0, 0.0};  ///< m/s, tracking frame
  double previous_rate = 0.0;
  // The gyro's previous sample (first unit only).
  bool gyro_open = false;
  double gyro_rate = 0.0;
};

}  // namespace

struct OtosReader::Impl {
  std::vector<Unit> units;
  OtosOptions options;
  LiveHooks hooks;
  OtosClock clock;
  double origin = 0.0;     ///< clock time of row t = 0
  double next_poll = 0.0;  ///< s, row clock
  double next_tick = 0.0;  ///< s, row clock
  std::deque<SensorRow> rows;
  std::vector<GyroSample> gyro;

  double now() const { return clock.now() - origin; }
  std::string where(const Unit& u) const {
    return fmt::format("{} ({})", u.link.device.name, u.link.transport->where());
  }
  void say_once(Unit& u, unsigned what, const std::string& text) {
    if ((u.said & what) != 0) return;
    u.said |= what;
    hooks.warning(fmt::format("{}: {} (further such reads are counted)", where(u), text));
  }

  void start_all(const RobotConfig& config) {
    std::set<std::pair<std::string, std::uint8_t>> buses;
    std::set<int> sensors;
    for (Unit& u : units) {
      const OtosDevice& d = u.link.device;
      if (d.sensor < 0 || d.sensor >= config.array.size()) {
        throw Error(fmt::format("{}: sensor index {} is not one of the config's {}", where(u),
                                d.sensor, config.array.size()));
      }
      if (!buses.insert({u.link.transport->where(), d.bus.address}).second) {
        throw Error(
            fmt::format("{}: a second unit at the same bus and address (OTOS units all "
                        "answer at 0x17: give each its own bus or multiplexer channel)",
                        where(u)));
      }
      if (!sensors.insert(d.sensor).second) {
        throw Error(fmt::format("{}: sensor '{}' is bound to two units", where(u), d.name));
      }
      u.counts = VelocityCounts(config.array[d.sensor].counts_per_metre());
      const OtosStart s = start_otos(*u.link.transport, options.start, clock.sleep);
      if (!s.info) throw Error(fmt::format("{}: {}", where(u), s.error.message));
      u.stats.info = *s.info;
      if (s.info->linear_scalar != 1.0 || s.info->angular_scalar != 1.0) {
        hooks.warning(fmt::format(
            "{}: its linear and angular scalars were {:.3f} and {:.3f}; moa set them to 1 (the "
            "config's scale and calibration hold the scale)",
            where(u), s.info->linear_scalar, s.info->angular_scalar));
      }
    }
    origin = clock.now();
    next_poll = 0.0;
    next_tick = hooks.tick_period;
  }

  void push_row(Unit& u, double t, const Vec2& counts, std::uint8_t flags,
                std::optional<std::uint8_t> squal) {
    SensorRow row;
    row.t = t;
    row.sensor = u.link.device.sensor;
    row.counts = counts;
    row.flags = flags;
    row.squal = squal;
    rows.push_back(row);
    ++u.stats.rows;
  }

  void go_silent(Unit& u, double t) {
    u.stats.answering = false;
    ++u.stats.silences;
    u.silent_since = t;
    u.last_try = t;
    u.has_previous = false;
    u.gyro_open = false;
    hooks.warning(fmt::format(
        "{}: stopped answering ({}) at t = {:.3f} s: its rows are flagged lift (left out) until "
        "it answers; tried again every {:g} s",
        where(u), u.last_error != 0 ? std::strerror(u.last_error) : "corrupt or impossible reads",
        t, options.retry_period));
  }

  // A silent unit: a start tried every retry_period; true when it answers.
  bool try_again(Unit& u, double t) {
    if (t - u.last_try < options.retry_period) return false;
    u.last_try = t;
    OtosStartOptions again = options.start;
    again.calibrate_imu = false;  // the robot may be moving
    const OtosStart s = start_otos(*u.link.transport, again, clock.sleep);
    if (!s.info) {
      u.last_error = s.error.error;
      return false;
    }
    u.stats.info = *s.info;
    u.stats.answering = true;
    u.last_good = t;  // a glitch right after is not a new silence yet
    u.counts.restart();
    hooks.warning(fmt::format(
        "{}: answers again after {:.3f} s (started again, without the IMU calibration); its "
        "motion while silent is lost",
        where(u), t - u.silent_since));
    return true;
  }

  void poll(std::size_t index) {
    Unit& u = units[index];
    if (!u.stats.answering) {
      const double t = now();
      if (!try_again(u, t)) {
        ++u.stats.silent_rows;
        push_row(u, std::max(t, last_row_t()), Vec2::Zero(), kFlagLift, std::nullopt);
        return;
      }
    }
    ++u.stats.polls;
    const double before = now();
    int error = 0;
    const std::optional<otos::Reading> reading = poll_otos(*u.link.transport, error);
    const double t = std::max(0.5 * (before + now()), last_row_t());
    const auto bad = [&] {
      if (t - u.last_good >= options.silent_after) go_silent(u, t);
    };
    if (!reading) {
      ++u.stats.read_errors;
      u.last_error = error;
      bad();
      return;
    }
    if ((reading->status & otos::kStatusReserved) != 0) {
      ++u.stats.corrupt;
      u.last_error = 0;
      say_once(u, kSaidCorrupt,
               fmt::format("status 0x{:02x} has reserved bits set at t = {:.3f} s: a corrupt "
                           "transfer, the read is dropped",
                           reading->status, t));
      bad();
      return;
    }
    // The unit's filters cannot change its velocity faster than its
    // accelerometer's full scale: a read that does is corrupt. Two LSB of
    // slack per axis for the rounding of either read.
    if (u.has_previous) {
      const double dt = t - u.previous_t;
      const double dv = (reading->velocity - u.previous_velocity).norm();
      const double dw = std::abs(reading->rate - u.previous_rate);
      const bool impossible =
          dv > options.max_acceleration * dt + 2.0 * std::sqrt(2.0) * otos::kVelocityLsb ||
          dw > options.max_angular_acceleration * dt + 2.0 * otos::kRateLsb;
      u.previous_t = t;
      u.previous_velocity = reading->velocity;
      u.previous_rate = reading->rate;
      if (impossible) {
        ++u.stats.implausible;
        u.last_error = 0;
        say_once(u, kSaidImplausible,
                 fmt::format("velocity changed by {:.3f} m/s (rate by {:.3f} rad/s) in {:.4f} s "
                             "at t = {:.3f} s, beyond its accelerometer's full scale: the read is "
                             "dropped",
                             dv, dw, dt, t));
        bad();
        return;
      }
    } else {
      u.has_previous = true;
      u.previous_t = t;
      u.previous_velocity = reading->velocity;
      u.previous_rate = reading->rate;
    }
    u.last_good = t;
    const std::uint8_t status = reading->status;
    std::uint8_t flags = 0;
    std::optional<std::uint8_t> squal;
    if (status & otos::kStatusOpticalTracking) {
      ++u.stats.tracking_lost;
      flags |= kFlagLift;
      say_once(u, kSaidTracking,
               fmt::format("optical tracking unreliable at t = {:.3f} s (status bit 1): its rows "
                           "are flagged lift (left out) while it lasts",
                           t));
    }
    if (status & otos::kStatusOpticalFault) {
      ++u.stats.optical_fault;
      flags |= kFlagLift;
      say_once(u, kSaidOpticalFault,
               fmt::format("its optical chip reports a fault at t = {:.3f} s (status bit 6): its "
                           "rows are flagged lift (left out) while it lasts",
                           t));
    }
    if (status & otos::kStatusTilt) {
      ++u.stats.tilt;
      squal = 0;
      say_once(u, kSaidTilt,
               fmt::format("tilted beyond its threshold at t = {:.3f} s (status bit 0): its rows "
                           "carry squal 0 (weighed less) while it lasts",
                           t));
    }
    const bool imu_fault = (status & otos::kStatusImuFault) != 0;
    if (imu_fault) {
      ++u.stats.imu_fault;
      squal = 0;
      say_once(u, kSaidImuFault,
               fmt::format("its IMU reports a fault at t = {:.3f} s (status bit 7): its rows "
                           "carry squal 0{} while it lasts",
                           t, index == 0 ? " and its gyro samples are withheld" : ""));
    }
    push_row(u, t, u.counts.add(t, otos::body_velocity(*reading)), flags, squal);
    if (index != 0) return;
    // The first unit's gyro: the trapezoid mean of its rate over the row's interval.
    if (imu_fault) {
      u.gyro_open = false;
      return;
    }
    if (reading->rate_saturated) {
      ++u.stats.rate_saturated;
      say_once(u, kSaidSaturated,
               fmt::format("its angular rate is at the register's full scale (2000 deg/s) at t "
                           "= {:.3f} s: the gyro sample is flagged saturated",
                           t));
    }
    if (u.gyro_open) {
      gyro.push_back({t, 0.5 * (u.gyro_rate + reading->rate), reading->rate_saturated});
    }
    u.gyro_open = true;
    u.gyro_rate = reading->rate;
  }

  double last_row_t() const { return rows.empty() ? last_t : std::max(last_t, rows.back().t); }
  double last_t = 0.0;  ///< the last row handed out

  void poll_all() {
    for (std::size_t i = 0; i < units.size(); ++i) poll(i);
  }
};

OtosReader::OtosReader(std::vector<OtosLink> units, const RobotConfig& config,
                       const OtosOptions& options, LiveHooks hooks, OtosClock clock)
    : impl_(std::make_unique<Impl>()) {
  if (const std::string e = options.validate(); !e.empty()) {
    throw Error(fmt::format("OTOS options: {}", e));
  }
  if (units.empty()) throw Error("OTOS: no unit given");
  impl_->options = options;
  impl_->hooks = std::move(hooks);
  impl_->clock = std::move(clock);
  for (OtosLink& link : units) {
    Unit u;
    u.link = std::move(link);
    impl_->units.push_back(std::move(u));
  }
  impl_->start_all(config);
}

namespace {

std::vector<OtosLink> open_devices(const std::vector<OtosDevice>& devices) {
  std::vector<OtosLink> links;
  for (const OtosDevice& d : devices) {
    try {
      links.push_back({d, std::make_unique<I2cDev>(d.bus.path, d.bus.address)});
    } catch (const IoError& e) {
      throw IoError(fmt::format("{}: {}", d.name, e.what()));
    } catch (const Error& e) {
      throw Error(fmt::format("{}: {}", d.name, e.what()));
    }
  }
  return links;
}

}  // namespace

OtosReader::OtosReader(const std::vector<OtosDevice>& devices, const RobotConfig& config,
                       const OtosOptions& options, LiveHooks hooks)
    : OtosReader(open_devices(devices), config, options, std::move(hooks), monotonic_clock()) {}

OtosReader::~OtosReader() = default;

double OtosReader::start_time() { return 0.0; }

std::optional<SensorRow> OtosReader::next() {
  Impl& m = *impl_;
  while (m.rows.empty()) {
    if (m.hooks.should_stop()) return std::nullopt;
    const double t = m.now();
    if (t >= m.next_tick) {
      if (m.hooks.tick) m.hooks.tick();
      m.next_tick = t + m.hooks.tick_period;
    }
    if (t < m.next_poll) {
      m.clock.sleep(std::min(m.next_poll, m.next_tick) - t);
      continue;
    }
    m.poll_all();
    // A poll that ran late starts the schedule again from now: no burst of
    // polls to catch up (the counts' dt is each interval's own).
    const double period = 1.0 / m.options.rate;
    m.next_poll += period;
    if (m.next_poll < t) m.next_poll = t + period;
  }
  SensorRow row = m.rows.front();
  m.rows.pop_front();
  m.last_t = row.t;
  return row;
}

std::vector<GyroSample> OtosReader::take_gyro() {
  std::vector<GyroSample> out;
  out.swap(impl_->gyro);
  return out;
}

int OtosReader::units() const { return static_cast<int>(impl_->units.size()); }

int OtosReader::answering() const {
  return static_cast<int>(std::count_if(impl_->units.begin(), impl_->units.end(),
                                        [](const Unit& u) { return u.stats.answering; }));
}

const OtosReader::UnitStats& OtosReader::stats(int unit) const {
  return impl_->units.at(static_cast<std::size_t>(unit)).stats;
}

const OtosDevice& OtosReader::device(int unit) const {
  return impl_->units.at(static_cast<std::size_t>(unit)).link.device;
}

std::string OtosReader::where(int unit) const {
  return impl_->where(impl_->units.at(static_cast<std::size_t>(unit)));
}

}  // namespace moa::io
