// SparkFun OTOS units on Linux I2C adapters (`moa live --otos`) as a
// FrameSource and a GyroStream.
//
// An OTOS unit is a sensor that measures its own point's velocity: each
// poll (every 1 / OtosOptions::rate s, all units in turn) reads its status,
// heading h and velocity v_track (sources/otos_unit.hpp), turns the
// velocity back into the unit's own frame, w = R(h)^T v_track
// (sources/otos_registers.hpp), and hands out a row of counts over the
// interval since its previous poll, as a mouse's counts:
//   counts_k = k (w_{k-1} + w_k) / 2 (t_k - t_{k-1}),  k = cpi / 0.0254 counts per metre,
// the trapezoid of the velocity over the interval, with cpi the unit's in
// the robot config (`moa config init --preset OTOS`: 25400, 1 um a count).
// Counts are whole (mice.csv holds integers): each is rounded and the
// remainder carried into the next, so that their sum stays within half a
// count of the integral. The core's measurement model then reads the unit
// as any sensor: counts / dt = k R(yaw)^T u (core/sensor.hpp), mirrored
// false, scale as calibrated. A unit's first poll opens its integral: a row
// of zero counts at its time.
//
// The first unit's angular rate is the gyro stream: one GyroSample per poll
// after its first, the trapezoid mean of its rate over the interval, at the
// row's t (its rows and its sample come together). Other units' rates are
// read (their headings turn their velocities back) but not fed: the
// pipeline has one gyro. While the first unit is silent its gyro has no
// samples; the first after it covers the silence with the rate it reads
// then (an imu row is the mean since the previous one).
//
// Time: row t = the middle of its poll's transfer on CLOCK_MONOTONIC, less
// the clock at the end of construction (units started), s. Polls of one
// unit are in time order, units in turn, so t never decreases.
//
// What the units say, and what becomes of it (each kind counted per unit and
// said once per unit through LiveHooks::warn):
//   status optical tracking unreliable, optical chip fault: the row is
//     flagged lift (SensorFlag kFlagLift): the estimators leave it out;
//   status tilt, IMU fault: squal 0 (the noise model's low-squal inflation);
//     an IMU fault also withholds the gyro sample;
//   reserved status bits set (a corrupt transfer), or a velocity that
//     changed faster than options.max_acceleration (or the rate faster than
//     max_angular_acceleration) since the previous read: the read is
//     dropped (no row; the next good read's interval covers it);
//   a failed transfer: no row; after silent_after s without a good read the
//     unit is silent: rows of zero counts flagged lift at every poll, and a
//     start (without the IMU calibration) tried every retry_period s; when
//     it answers (its product ID checked again) its integral restarts.
// Bad readings never end the stream; only the stop hook does.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "moa/formats/config.hpp"
#include "moa/formats/log.hpp"
#include "moa/sources/i2c_dev.hpp"
#include "moa/sources/i2c_transport.hpp"
#include "moa/sources/live.hpp"
#include "moa/sources/otos_unit.hpp"

namespace moa::io {

struct OtosDevice {
  std::string name;  ///< the sensor's name in the config, for messages
  I2cAddress bus;    ///< adapter and address
  int sensor = 0;    ///< row.sensor of its rows (index in the config)
};

struct OtosOptions {
  /// Hz, polls of every unit per second: kMinRate to the unit's loop rate
  /// (otos::kLoopRate, about 416.7; faster reads would repeat samples).
  /// kMinRate keeps a row's interval within the synchroniser's default
  /// max_row_interval (0.05 s) with room for a late poll.
  double rate = 200.0;
  static constexpr double kMinRate = 25.0;
  OtosStartOptions start;
  double silent_after = 0.03;  ///< s without a good read before a unit is silent
  double retry_period = 0.1;   ///< s between starts tried on a silent unit
  /// m/s^2 and rad/s^2: the full scales of the unit's acceleration
  /// registers (16 g, 1000 pi rad/s^2). Its own filters cannot report a
  /// faster change of velocity or rate; a read that does is corrupt.
  double max_acceleration = 16.0 * otos::kGravity;
  double max_angular_acceleration = 1000.0 * std::numbers::pi;
  /// Empty when usable, else "field: must be ..., is ...".
  std::string validate() const;
};

/// A unit's body-frame velocity samples to whole counts (see the top).
class VelocityCounts {
 public:
  explicit VelocityCounts(double counts_per_metre) : k_(counts_per_metre) {}
  /// The counts over (previous t, t]; zero for the first sample after
  /// construction or restart() (it opens the integral).
  Vec2 add(double t, const Vec2& w);
  /// The next sample opens a new integral; the remainder is dropped.
  void restart() { open_ = false; }
  /// The remainder carried, counts (|each| <= 0.5).
  const Vec2& remainder() const { return remainder_; }

 private:
  double k_;
  bool open_ = false;
  double t_ = 0.0;
  Vec2 w_{0.0, 0.0};
  Vec2 remainder_{0.0, 0.0};
};

/// The reader's clock: `now` in seconds (CLOCK_MONOTONIC for devices),
/// `sleep` for the given seconds. A test's clock may advance on sleep only.
struct OtosClock {
  std::function<double()> now;
  std::function<void(double)> sleep;
};
OtosClock monotonic_clock();

/// A unit and its transport (a test's register model, or I2cDev).
struct OtosLink {
  OtosDevice device;
  std::unique_ptr<I2cTransport> transport;
};

class OtosReader final : public FrameSource, public GyroStream {
 public:
  struct UnitStats {
    bool answering = true;
    std::uint64_t polls = 0;           ///< transfers tried
    std::uint64_t rows = 0;            ///< rows handed out (lift rows of a silence included)
    std::uint64_t read_errors = 0;     ///< failed transfers
    std::uint64_t silences = 0;        ///< times it went silent
    std::uint64_t silent_rows = 0;     ///< lift rows while silent
    std::uint64_t tracking_lost = 0;   ///< reads with optical tracking unreliable
    std::uint64_t optical_fault = 0;   ///< reads with the optical chip's fault bit
    std::uint64_t tilt = 0;            ///< reads with the tilt bit
    std::uint64_t imu_fault = 0;       ///< reads with the IMU's fault bit
    std::uint64_t corrupt = 0;         ///< reads with reserved status bits, dropped
    std::uint64_t implausible = 0;     ///< reads with an impossible change, dropped
    std::uint64_t rate_saturated = 0;  ///< gyro samples at the rate's full scale
    OtosInfo info;                     ///< from its (last) start
  };

  /// Opens every unit's adapter (I2cDev) and starts the units. Throws
  /// io::Error "NAME (PATH:ADDR): why" for an adapter that cannot be used, a
  /// unit that does not answer or is not an OTOS, bad options, a unit bound
  /// twice to one bus and address or to one sensor.
  OtosReader(const std::vector<OtosDevice>& devices, const RobotConfig& config,
             const OtosOptions& options, LiveHooks hooks);
  /// The same over given transports and clock (tests).
  OtosReader(std::vector<OtosLink> units, const RobotConfig& config, const OtosOptions& options,
             LiveHooks hooks, OtosClock clock);
  ~OtosReader() override;

  /// 0: rows are relative to the clock when the units were started.
  double start_time() override;
  /// Blocks until a row or the stop hook (ticking LiveHooks::tick).
  std::optional<SensorRow> next() override;
  std::vector<GyroSample> take_gyro() override;

  int units() const;
  int answering() const;
  const UnitStats& stats(int unit) const;
  const OtosDevice& device(int unit) const;
  std::string where(int unit) const;  ///< "NAME (PATH:ADDR)"

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace moa::io
