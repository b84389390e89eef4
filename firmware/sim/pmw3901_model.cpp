#include "pmw3901_model.hpp"

#include <utility>

namespace moa::firmware_sim {

namespace {

constexpr std::uint8_t kRegProductId = 0x00;
constexpr std::uint8_t kRegRevisionId = 0x01;
constexpr std::uint8_t kRegMotion = 0x02;
constexpr std::uint8_t kRegMotionBurst = 0x16;
constexpr std::uint8_t kRegPowerUpReset = 0x3A;
constexpr std::uint8_t kRegInverseProductId = 0x5F;
constexpr std::uint8_t kRegBank = 0x7F;
constexpr std::uint8_t kTrimBank = 0x0E;
constexpr std::uint8_t kMotionMot = 0x80;

}  // namespace

Pmw3901Model::Pmw3901Model(std::vector<MotionFrame> script, Trim trim, std::uint8_t product_id,
                           std::uint8_t idle_squal)
    : script_(std::move(script)), trim_(trim), product_id_(product_id), idle_squal_(idle_squal) {}

void Pmw3901Model::reset_pin(bool high, double t_us) {
  if (high == nreset_high_) return;
  nreset_high_ = high;
  if (!high && selected_) violation(t_us, "NRESET pulled low while selected");
}

void Pmw3901Model::ncs_pin(bool high, double t_us) {
  const bool select = !high;
  if (select == selected_) return;
  selected_ = select;
  if (select) {
    state_ = t_us >= silent_from_us_ ? State::kSilent : State::kAddress;
    return;
  }
  if (state_ == State::kReadData || state_ == State::kWriteData) {
    violation(t_us, "NCS raised in the middle of a command to " + hex(address_));
  }
  state_ = State::kAddress;
}

std::uint8_t Pmw3901Model::read_register(std::uint8_t address, double t_us) {
  if (bank_ == 0 && address >= kRegMotion && address <= kRegMotion + 4) {
    motion_read_[address - kRegMotion] = true;
    return 0x00;
  }
  if (bank_ == 0 && address == kRegProductId) return product_id_;
  if (bank_ == 0 && address == kRegRevisionId) return 0x00;
  if (bank_ == 0 && address == kRegInverseProductId) return static_cast<std::uint8_t>(~product_id_);
  if (bank_ == kTrimBank) {
    switch (address) {
      case 0x67:
        return trim_.r67;
      case 0x70:
        return trim_.r70;
      case 0x71:
        return trim_.r71;
      case 0x73:
        return trim_.r73;
      default:
        break;
    }
  }
  violation(t_us, "read of register " + hex(address) + " in bank " + hex(bank_) +
                      ", which the model does not have");
  return 0x00;
}

void Pmw3901Model::start_burst(double t_us) {
  if (bank_ != 0) violation(t_us, "Motion_Burst read outside bank 0");
  const MotionFrame f = burst_times_.size() < script_.size() ? script_[burst_times_.size()]
                                                             : MotionFrame{0, 0, idle_squal_};
  std::uint8_t motion = 0;
  if (f.dx != 0 || f.dy != 0) motion |= kMotionMot;
  const auto u = [](std::int16_t v) { return static_cast<std::uint16_t>(v); };
  // Motion, Observation, Delta_X_L, _H, Delta_Y_L, _H, SQUAL, RawData_Sum,
  // Maximum_RawData, Minimum_RawData, Shutter_Upper, Shutter_Lower.
  burst_ = {motion,
            0xBF,
            static_cast<std::uint8_t>(u(f.dx) & 0xFF),
            static_cast<std::uint8_t>(u(f.dx) >> 8),
            static_cast<std::uint8_t>(u(f.dy) & 0xFF),
            static_cast<std::uint8_t>(u(f.dy) >> 8),
            f.squal,
            0x40,
            0x90,
            0x08,
            static_cast<std::uint8_t>(f.shutter >> 8),
            static_cast<std::uint8_t>(f.shutter & 0xFF)};
  burst_at_ = 0;
  burst_times_.push_back(t_us);
}

std::uint8_t Pmw3901Model::exchange(std::uint8_t mosi, double start_us, double end_us) {
  ++accesses_;
  if (state_ == State::kSilent || start_us >= silent_from_us_) {
    state_ = State::kSilent;
    return 0xFF;
  }
  if (!nreset_high_) violation(start_us, "SPI access while NRESET is low");
  switch (state_) {
    case State::kAddress: {
      const bool write = (mosi & 0x80) != 0;
      address_ = static_cast<std::uint8_t>(mosi & 0x7f);
      address_end_us_ = end_us;
      if (reset_at_us_ < 0.0 && !(write && address_ == kRegPowerUpReset)) {
        violation(start_us, "access to " + hex(address_) + " before the Power_Up_Reset write");
      }
      if (reset_at_us_ >= 0.0 && start_us - reset_at_us_ < timing_.t_power_up) {
        violation(start_us, "access sooner than 1 ms after Power_Up_Reset");
      }
      if (start_us - last_write_end_us_ < timing_.t_sww) {
        violation(start_us, "command sooner than t_SWW/t_SWR (45 us) after a write");
      }
      if (start_us - last_read_end_us_ < timing_.t_srr) {
        violation(start_us, "command sooner than t_SRR/t_SRW (20 us) after a read");
      }
      if (write) {
        state_ = State::kWriteData;
      } else if (address_ == kRegMotionBurst) {
        state_ = State::kBurst;
        start_burst(start_us);
      } else {
        state_ = State::kReadData;
      }
      return 0;
    }
    case State::kReadData:
      if (start_us - address_end_us_ < timing_.t_srad) {
        violation(start_us, "data of " + hex(address_) + " read sooner than t_SRAD (35 us)");
      }
      state_ = State::kAddress;
      last_read_end_us_ = end_us;
      return read_register(address_, start_us);
    case State::kWriteData:
      if (address_ == kRegPowerUpReset && mosi == 0x5A) {
        reset_at_us_ = start_us;
        bank_ = 0;
        writes_.clear();
        for (bool& r : motion_read_) r = false;
      } else {
        bool all_read = true;
        for (const bool r : motion_read_) all_read = all_read && r;
        if (!all_read && writes_.empty()) {
          violation(start_us, "init sequence before registers 0x02..0x06 were read once");
        }
        writes_.push_back(Write{bank_, address_, mosi, start_us});
        if (address_ == kRegBank) bank_ = mosi;
      }
      last_write_end_us_ = end_us;
      state_ = State::kAddress;
      return 0;
    case State::kBurst:
      if (burst_at_ == 0 && start_us - address_end_us_ < timing_.t_srad) {
        violation(start_us, "burst data read sooner than t_SRAD (35 us) after 0x16");
      }
      if (burst_at_ >= burst_.size()) {
        violation(start_us, "motion burst longer than its 12 bytes");
        return 0;
      }
      return burst_[burst_at_++];
    case State::kSilent:
      break;
  }
  return 0xFF;
}

}  // namespace moa::firmware_sim
