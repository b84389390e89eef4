#include "adns3080_model.hpp"

#include <cstdio>
#include <utility>

namespace moa::firmware_sim {

namespace {

constexpr std::uint8_t kRegProductId = 0x00;
constexpr std::uint8_t kRegMotion = 0x02;
constexpr std::uint8_t kRegConfigurationBits = 0x0a;
constexpr std::uint8_t kRegMotionBurst = 0x50;
constexpr std::uint8_t kMotionMot = 0x80;
constexpr std::uint8_t kMotionOvf = 0x10;
constexpr std::uint8_t kMotionRes = 0x01;
constexpr std::uint8_t kConfigRes1600 = 0x10;

}  // namespace

Adns3080Model::Adns3080Model(std::vector<MotionFrame> script, std::uint8_t product_id,
                             std::uint8_t idle_squal)
    : script_(std::move(script)), product_id_(product_id), idle_squal_(idle_squal) {}

void Adns3080Model::reset_pin(bool high, double t_us) {
  if (high == reset_high_) return;
  reset_high_ = high;
  if (high) {
    reset_rise_us_ = t_us;
    return;
  }
  if (t_us - reset_rise_us_ < timing_.t_reset) {
    violation(t_us, "RESET pulse shorter than 10 us");
    return;
  }
  was_reset_ = true;
  configuration_ = kConfigurationReset;
  state_ = State::kAddress;
}

void Adns3080Model::ncs_pin(bool high, double t_us) {
  const bool select = !high;
  if (select == selected_) return;
  selected_ = select;
  if (select) {
    if (last_was_burst_ && t_us - deselect_us_ < timing_.t_bexit) {
      violation(t_us, "NCS high for less than t_BEXIT (4 us) after a burst");
    }
    state_ = State::kAddress;
    return;
  }
  if (state_ == State::kReadData || state_ == State::kWriteData) {
    violation(t_us, "NCS raised in the middle of a command to " + hex(address_));
  }
  last_was_burst_ = state_ == State::kBurst;
  deselect_us_ = t_us;
  state_ = State::kAddress;
}

std::uint8_t Adns3080Model::read_register(std::uint8_t address) const {
  switch (address) {
    case kRegProductId:
      return product_id_;
    case kRegConfigurationBits:
      return configuration_;
    default:
      return 0;
  }
}

std::uint8_t Adns3080Model::exchange(std::uint8_t mosi, double start_us, double end_us) {
  ++accesses_;
  if (!was_reset_) violation(start_us, "SPI access before a RESET pulse");
  switch (state_) {
    case State::kAddress: {
      if (start_us - last_write_end_us_ < timing_.t_sww) {
        violation(start_us, "command sooner than t_SWW/t_SWR (50 us) after a write");
      }
      address_ = static_cast<std::uint8_t>(mosi & 0x7f);
      address_end_us_ = end_us;
      if (mosi & 0x80) {
        state_ = State::kWriteData;
      } else if (address_ == kRegMotionBurst) {
        state_ = State::kBurst;
        const MotionFrame frame = burst_times_.size() < script_.size()
                                      ? script_[burst_times_.size()]
                                      : MotionFrame{0, 0, idle_squal_, false};
        std::uint8_t motion = 0;
        if (frame.dx != 0 || frame.dy != 0) motion |= kMotionMot;
        if (frame.overflow) motion |= kMotionOvf;
        if (configuration_ & kConfigRes1600) motion |= kMotionRes;
        // Motion, Delta_X, Delta_Y, SQUAL, Shutter_Upper, Shutter_Lower, Maximum_Pixel.
        burst_ = {motion,
                  static_cast<std::uint8_t>(frame.dx),
                  static_cast<std::uint8_t>(frame.dy),
                  frame.squal,
                  0x01,
                  0x00,
                  0x20};
        burst_at_ = 0;
        burst_times_.push_back(start_us);
      } else if (address_ == kRegProductId || address_ == kRegConfigurationBits) {
        state_ = State::kReadData;
      } else {
        violation(start_us,
                  "read of register " + hex(address_) + ", which the model does not have");
        state_ = State::kReadData;
      }
      // The sensor drives nothing meaningful while it receives an address.
      return 0;
    }
    case State::kReadData: {
      const double wait = address_ == kRegMotion ? timing_.t_srad_mot : timing_.t_srad;
      if (start_us - address_end_us_ < wait) {
        violation(start_us,
                  "data of " + hex(address_) + " read sooner than t_SRAD after its address");
      }
      state_ = State::kAddress;
      return read_register(address_);
    }
    case State::kWriteData:
      if (address_ == kRegConfigurationBits) {
        configuration_ = mosi;
      } else {
        violation(start_us, "write to register " + hex(address_));
      }
      last_write_end_us_ = end_us;
      state_ = State::kAddress;
      return 0;
    case State::kBurst:
      if (burst_at_ == 0 && start_us - address_end_us_ < timing_.t_srad_mot) {
        violation(start_us, "burst data read sooner than t_SRAD-MOT (75 us) after 0x50");
      }
      if (burst_at_ >= burst_.size()) {
        violation(start_us, "motion burst longer than its 7 bytes");
        return 0;
      }
      return burst_[burst_at_++];
  }
  return 0;
}

}  // namespace moa::firmware_sim
