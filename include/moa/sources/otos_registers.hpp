// The register map of SparkFun's Optical Tracking Odometry Sensor (OTOS:
// PixArt's PAA5160 optical chip, an LSM6DSO gyro and accelerometer, and a
// microcontroller that fuses them), as its I2C slave at 0x17 presents it.
// Pure: bytes in, SI units out, and back; no I/O (sources/otos_unit.hpp
// talks to a unit through an I2cTransport).
//
// Every pose-like quantity is a triple (x, y, h) of little-endian int16
// (low byte first) at six consecutive registers, each read with a fixed
// scale (units per least significant bit, LSB):
//   position, offset, their sd  x, y: 10 m / 32768        h: pi rad / 32768
//   velocity, its sd            x, y: 5 m/s / 32768       h: 2000 deg/s / 32768
//   acceleration, its sd        x, y: 16 g / 32768        h: 1000 pi rad/s^2 / 32768
// (g = 9.80665 m/s^2), i.e. each register spans [-full scale, full scale).
// The linear and angular scalars are int8 in steps of 0.1 %: scalar =
// 1 + 0.001 n, n in -128..127, of which the unit accepts 0.872..1.127.
//
// Frames. The unit integrates its own pose in its tracking frame: the
// frame its x, y axes had at the last reset of tracking, heading h
// counter-clockwise seen from above (its offset registers at 0, as moa
// sets them: the pose is its own point's). Its velocity registers hold that
// point's velocity v_track in the tracking frame, so the velocity in the
// unit's own (body) frame is
//   w = R(h)^T v_track,  R(h) = [[cos h, -sin h], [sin h, cos h]],
// with h its heading register at the same poll; the angular rate (velocity
// h) is the rate of turn about z, counter-clockwise, rad/s.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <optional>
#include <span>

#include "moa/core/se2.hpp"

namespace moa::io::otos {

inline constexpr std::uint8_t kDefaultAddress = 0x17;
/// What the product ID register of every OTOS reads.
inline constexpr std::uint8_t kProductId = 0x5F;

/// Register addresses. A triple's six registers start at its address
/// (x low, x high, y low, y high, h low, h high); reads auto-increment.
enum Register : std::uint8_t {
  kRegProductId = 0x00,
  kRegHardwareVersion = 0x01,  ///< major in the high nibble, minor in the low
  kRegFirmwareVersion = 0x02,
  kRegLinearScalar = 0x04,
  kRegAngularScalar = 0x05,
  /// Written n: the unit averages n samples (2.4 ms each) at rest for its
  /// gyro and accelerometer offsets; reads the samples left, 0 when done.
  kRegImuCalibration = 0x06,
  kRegReset = 0x07,
  kRegSignalProcess = 0x0E,
  kRegSelfTest = 0x0F,
  kRegOffset = 0x10,
  kRegStatus = 0x1F,
  kRegPosition = 0x20,
  kRegVelocity = 0x26,
  kRegAcceleration = 0x2C,
  kRegPositionSd = 0x32,
  kRegVelocitySd = 0x38,
  kRegAccelerationSd = 0x3E,
};

/// Status register bits.
enum StatusBit : std::uint8_t {
  kStatusTilt = 1u << 0,  ///< tilted beyond its threshold: its accelerometer is ignored
  /// optical tracking unreliable: the unit tracks on its IMU alone
  kStatusOpticalTracking = 1u << 1,
  /// bits 2..5, reserved: moa takes a status with any of them set for a
  /// corrupt transfer
  kStatusReserved = 0x3C,
  kStatusOpticalFault = 1u << 6,  ///< the optical chip (PAA5160) failed
  kStatusImuFault = 1u << 7,      ///< the IMU (LSM6DSO) failed
};

/// Signal-process register bits (all set at power-up).
enum SignalProcessBit : std::uint8_t {
  kSignalLut = 1u << 0,            ///< the optical chip's calibration table
  kSignalAccelerometer = 1u << 1,  ///< the accelerometer fed to its filters
  kSignalRotation = 1u << 2,       ///< optical and IMU data turned by the heading
  kSignalVariance = 1u << 3,       ///< its filters' variances (clear: filters off)
};

/// Reset register bit: restart tracking at the origin, heading 0.
inline constexpr std::uint8_t kResetTracking = 1u << 0;

/// The unit's internal loop: one sample every 2.4 ms.
inline constexpr double kLoopPeriod = 0.0024;           ///< s
inline constexpr double kLoopRate = 1.0 / kLoopPeriod;  ///< Hz, about 416.7

// Scales, SI units per LSB.
inline constexpr double kLsbPerFullScale = 32768.0;
inline constexpr double kGravity = 9.80665;                                 ///< m/s^2 per g
inline constexpr double kPositionLsb = 10.0 / kLsbPerFullScale;             ///< m
inline constexpr double kHeadingLsb = std::numbers::pi / kLsbPerFullScale;  ///< rad
inline constexpr double kVelocityLsb = 5.0 / kLsbPerFullScale;              ///< m/s
inline constexpr double kRateLsb = 2000.0 * std::numbers::pi / 180.0 / kLsbPerFullScale;  ///< rad/s
inline constexpr double kAccelerationLsb = 16.0 * kGravity / kLsbPerFullScale;            ///< m/s^2
inline constexpr double kAngularAccelerationLsb =
    1000.0 * std::numbers::pi / kLsbPerFullScale;  ///< rad/s^2
inline constexpr double kScalarLsb = 0.001;
inline constexpr double kMinScalar = 0.872;
inline constexpr double kMaxScalar = 1.127;

/// A triple's raw register values.
struct RawTriple {
  std::int16_t x = 0, y = 0, h = 0;
};
/// A triple in SI units (m or m/s or m/s^2 for x, y; rad, rad/s or rad/s^2 for h).
struct Triple {
  Vec2 xy{0.0, 0.0};
  double h = 0.0;
};
/// The scales of one kind of triple.
struct TripleScale {
  double xy;  ///< per LSB
  double h;   ///< per LSB
};
inline constexpr TripleScale kPositionScale{kPositionLsb, kHeadingLsb};
inline constexpr TripleScale kVelocityScale{kVelocityLsb, kRateLsb};
inline constexpr TripleScale kAccelerationScale{kAccelerationLsb, kAngularAccelerationLsb};

/// Six register bytes (x low first) to raw values.
RawTriple decode_raw(std::span<const std::uint8_t, 6> bytes);
/// Raw values to six register bytes.
void encode_raw(const RawTriple& raw, std::span<std::uint8_t, 6> bytes);
/// raw x scale.
Triple to_si(const RawTriple& raw, const TripleScale& scale);
/// The nearest raw values (half away from zero), saturated to the int16
/// range: what a unit holds for a value written to it.
RawTriple to_raw(const Triple& value, const TripleScale& scale);

/// A scalar register's value: 1 + 0.001 x (int8) n.
double scalar_from_register(std::uint8_t value);
/// The register value of a scalar in kMinScalar..kMaxScalar (nearest step);
/// nullopt outside (or not finite).
std::optional<std::uint8_t> scalar_register(double scalar);

/// One poll: kPollBytes read from kRegStatus on, which is the status, the
/// position triple and the velocity triple (registers 0x1F..0x2B).
inline constexpr std::size_t kPollBytes = 13;
struct Reading {
  std::uint8_t status = 0;
  Vec2 position{0.0, 0.0};  ///< m, tracking frame
  double heading = 0.0;     ///< rad, the unit's x axis from the tracking frame's x, in [-pi, pi)
  Vec2 velocity{0.0, 0.0};  ///< m/s, its point's velocity in the tracking frame
  double rate = 0.0;        ///< rad/s, counter-clockwise
  bool rate_saturated = false;  ///< the rate register at its full scale (+-32767 or -32768)
};
Reading decode_poll(std::span<const std::uint8_t, kPollBytes> bytes);

/// The turn-back: the velocity in the unit's own frame, w = R(h)^T v_track.
Vec2 body_velocity(const Reading& reading);

}  // namespace moa::io::otos
