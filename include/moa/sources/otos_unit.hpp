// One OTOS unit over an I2cTransport (sources/otos_registers.hpp for the
// map): how moa starts it and reads it.
//
// Start (start_otos): the product ID must read 0x5F; the versions are read;
// the offset is written 0 (so the unit reports its own point, whose mount
// is moa's config), both scalars 1 (moa's config and calibration hold the
// scale), the signal-process register keeps its bits with rotation by the
// heading set (the turn-back below assumes it); optionally the IMU is
// calibrated (the robot must stand still: 255 samples, about 0.6 s); then
// tracking is reset (pose 0, heading 0). The unit forgets all of these at a
// power cycle, so a unit that comes back mid-run is started again.
//
// Poll (poll_otos): kPollBytes from the status register on, in one
// transfer: status, position, heading, velocity and angular rate of the
// same loop of the unit.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "moa/sources/i2c_transport.hpp"
#include "moa/sources/otos_registers.hpp"

namespace moa::io {

struct OtosStartOptions {
  /// Calibrate the gyro and accelerometer offsets at start (robot at rest).
  bool calibrate_imu = true;
  /// Samples averaged by the IMU calibration (1..255), 2.4 ms each.
  int imu_samples = 255;
};

struct OtosInfo {
  std::uint8_t hardware_version = 0;  ///< major in the high nibble
  std::uint8_t firmware_version = 0;
  /// The scalars the unit held before moa set them to 1 (1 after a power-up).
  double linear_scalar = 1.0;
  double angular_scalar = 1.0;
};

/// Why a start failed; `message` is one line without the unit's name.
struct OtosStartError {
  int error = 0;  ///< errno of the failed transfer, 0 for a wrong answer
  std::string message;
};

/// Starts the unit as above. `sleep` waits the given seconds (the IMU
/// calibration's polls). Returns the info, or the first failure: no answer
/// (the transfer's errno), a product ID that is not the OTOS's, an IMU
/// calibration that does not finish in 3 ms per sample plus 0.1 s.
struct OtosStart {
  std::optional<OtosInfo> info;
  OtosStartError error;
};
OtosStart start_otos(I2cTransport& unit, const OtosStartOptions& options,
                     const std::function<void(double)>& sleep);

/// One poll; nullopt with `error` set to the transfer's errno when it failed.
std::optional<otos::Reading> poll_otos(I2cTransport& unit, int& error);

}  // namespace moa::io
