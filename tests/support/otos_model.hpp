// A register model of a SparkFun OTOS for tests: an io::I2cTransport that
// holds the unit's register file, answers reads and writes as a unit does
// (product ID, auto-increment, the IMU calibration's countdown, the reset of
// tracking), can stop answering, and, driven by a constant robot twist and
// the test's clock, fills its heading, velocity and rate registers as a
// unit at a given mount would (docs in sources/otos_registers.hpp).
#pragma once

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "moa/core/se2.hpp"
#include "moa/core/sensor.hpp"
#include "moa/sources/i2c_transport.hpp"
#include "moa/sources/otos_registers.hpp"

namespace moa::test {

struct OtosModelState {
  std::array<std::uint8_t, 256> regs{};
  bool answering = true;
  int error = EREMOTEIO;  ///< what a transfer returns while not answering
  std::string where = "model:0x17";
  std::vector<std::pair<std::uint8_t, std::vector<std::uint8_t>>> writes;
  int status_reads = 0;
  /// Samples the IMU calibration counts down per read of its register.
  int calibration_step = 64;
  /// Called before each read from the status register on (a poll), to
  /// fill the registers for the moment of the read.
  std::function<void(OtosModelState&)> before_poll;
  /// Called at a write of the reset register (tracking restarts).
  std::function<void(OtosModelState&)> on_reset;

  OtosModelState() {
    regs[io::otos::kRegProductId] = io::otos::kProductId;
    regs[io::otos::kRegHardwareVersion] = 0x10;
    regs[io::otos::kRegFirmwareVersion] = 0x10;
    regs[io::otos::kRegSignalProcess] = 0x0F;
  }
  void set_triple(std::uint8_t reg, const io::otos::Triple& value,
                  const io::otos::TripleScale& scale) {
    io::otos::encode_raw(io::otos::to_raw(value, scale),
                         std::span<std::uint8_t, 6>(regs.data() + reg, 6));
  }
};

class OtosModel final : public io::I2cTransport {
 public:
  explicit OtosModel(std::shared_ptr<OtosModelState> state) : s_(std::move(state)) {}

  int read(std::uint8_t reg, std::span<std::uint8_t> out) override {
    if (!s_->answering) return s_->error;
    if (reg == io::otos::kRegStatus) {
      ++s_->status_reads;
      if (s_->before_poll) s_->before_poll(*s_);
    }
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = s_->regs[(reg + i) & 0xFFu];
    std::uint8_t& left = s_->regs[io::otos::kRegImuCalibration];
    if (reg == io::otos::kRegImuCalibration && left > 0) {
      left = static_cast<std::uint8_t>(std::max(0, left - s_->calibration_step));
    }
    return 0;
  }
  int write(std::uint8_t reg, std::span<const std::uint8_t> data) override {
    if (!s_->answering) return s_->error;
    s_->writes.emplace_back(reg, std::vector<std::uint8_t>(data.begin(), data.end()));
    for (std::size_t i = 0; i < data.size(); ++i) s_->regs[(reg + i) & 0xFFu] = data[i];
    if (reg == io::otos::kRegReset && (data[0] & io::otos::kResetTracking) && s_->on_reset) {
      s_->on_reset(*s_);
    }
    return 0;
  }
  std::string where() const override { return s_->where; }

 private:
  std::shared_ptr<OtosModelState> s_;
};

/// A unit at `mount` on a robot moving with a constant twist (robot frame)
/// from the unit's reset of tracking on: at time tau after the reset its
/// heading is h = omega tau (relative to its frame at the reset), its
/// point's velocity in its own frame w = R(yaw)^T (v + omega J p), in its
/// tracking frame R(h) w; the registers hold them rounded (to_raw).
/// Its position x, y stay 0 (moa reads the heading only). `now` is the
/// test's clock (s).
inline void drive_otos_model(OtosModelState& state, const SensorMount& mount, const Twist2& twist,
                             std::function<double()> now) {
  auto reset_at = std::make_shared<double>(now());
  state.on_reset = [reset_at, now](OtosModelState&) { *reset_at = now(); };
  state.before_poll = [reset_at, now, mount, twist](OtosModelState& s) {
    const double tau = now() - *reset_at;
    const double h = twist.omega * tau;
    const Vec2 u = twist.v + twist.omega * skew_unit() * mount.position;
    const Vec2 w = rotation(mount.yaw).transpose() * u;
    const double wrapped = std::remainder(h, 2.0 * M_PI);
    s.set_triple(io::otos::kRegPosition, {Vec2::Zero(), wrapped}, io::otos::kPositionScale);
    s.set_triple(io::otos::kRegVelocity, {rotation(h) * w, twist.omega}, io::otos::kVelocityScale);
  };
}

}  // namespace moa::test
