#include "moa/sources/otos_unit.hpp"

#include <fmt/core.h>

#include <array>
#include <cstring>

namespace moa::io {
namespace {

OtosStart failed(int error, std::string message) {
  OtosStart out;
  out.error = {error, std::move(message)};
  return out;
}

std::string no_answer(int error, const char* what) {
  return fmt::format("does not answer ({}: {}): check its wiring, power and address (i2cdetect)",
                     what, std::strerror(error));
}

}  // namespace

OtosStart start_otos(I2cTransport& unit, const OtosStartOptions& options,
                     const std::function<void(double)>& sleep) {
  using namespace otos;
  std::array<std::uint8_t, 3> id{};  // product ID, hardware and firmware versions
  if (const int e = unit.read(kRegProductId, id)) return failed(e, no_answer(e, "product ID"));
  if (id[0] != kProductId) {
    return failed(0, fmt::format("product ID 0x{:02x}, an OTOS reads 0x{:02x}: another device "
                                 "at this address?",
                                 id[0], kProductId));
  }
  OtosInfo info;
  info.hardware_version = id[1];
  info.firmware_version = id[2];
  std::array<std::uint8_t, 2> scalars{};
  if (const int e = unit.read(kRegLinearScalar, scalars)) return failed(e, no_answer(e, "scalars"));
  info.linear_scalar = scalar_from_register(scalars[0]);
  info.angular_scalar = scalar_from_register(scalars[1]);
  const std::array<std::uint8_t, 2> unity{*scalar_register(1.0), *scalar_register(1.0)};
  if (const int e = unit.write(kRegLinearScalar, unity)) return failed(e, no_answer(e, "scalars"));
  const std::array<std::uint8_t, 6> zero_offset{};
  if (const int e = unit.write(kRegOffset, zero_offset)) return failed(e, no_answer(e, "offset"));
  std::array<std::uint8_t, 1> signal{};
  if (const int e = unit.read(kRegSignalProcess, signal)) {
    return failed(e, no_answer(e, "signal-process config"));
  }
  if ((signal[0] & kSignalRotation) == 0) {
    signal[0] = static_cast<std::uint8_t>(signal[0] | kSignalRotation);
    if (const int e = unit.write(kRegSignalProcess, signal)) {
      return failed(e, no_answer(e, "signal-process config"));
    }
  }
  if (options.calibrate_imu) {
    const std::array<std::uint8_t, 1> samples{static_cast<std::uint8_t>(options.imu_samples)};
    if (const int e = unit.write(kRegImuCalibration, samples)) {
      return failed(e, no_answer(e, "IMU calibration"));
    }
    // 3 ms a sample (the unit's 2.4 ms loop, with margin), plus 0.1 s.
    const double limit = 0.003 * options.imu_samples + 0.1;
    double waited = 0.0;
    for (;;) {
      sleep(0.003);
      waited += 0.003;
      std::array<std::uint8_t, 1> left{};
      if (const int e = unit.read(kRegImuCalibration, left)) {
        return failed(e, no_answer(e, "IMU calibration"));
      }
      if (left[0] == 0) break;
      if (waited > limit) {
        return failed(0, fmt::format("IMU calibration did not finish in {:.2f} s ({} samples "
                                     "left of {})",
                                     limit, left[0], options.imu_samples));
      }
    }
  }
  const std::array<std::uint8_t, 1> reset{kResetTracking};
  if (const int e = unit.write(kRegReset, reset)) return failed(e, no_answer(e, "reset"));
  OtosStart out;
  out.info = info;
  return out;
}

std::optional<otos::Reading> poll_otos(I2cTransport& unit, int& error) {
  std::array<std::uint8_t, otos::kPollBytes> bytes{};
  error = unit.read(otos::kRegStatus, bytes);
  if (error != 0) return std::nullopt;
  return otos::decode_poll(bytes);
}

}  // namespace moa::io
