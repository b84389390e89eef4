#include "pmw33xx_model.hpp"

#include <utility>

namespace moa::firmware_sim {

namespace {

constexpr std::uint8_t kRegProductId = 0x00;
constexpr std::uint8_t kRegMotion = 0x02;
constexpr std::uint8_t kRegResolutionL = 0x0E;
constexpr std::uint8_t kRegConfig1 = 0x0F;
constexpr std::uint8_t kRegConfig2 = 0x10;
constexpr std::uint8_t kRegSromEnable = 0x13;
constexpr std::uint8_t kRegDataOutLower = 0x25;
constexpr std::uint8_t kRegDataOutUpper = 0x26;
constexpr std::uint8_t kRegSromId = 0x2A;
constexpr std::uint8_t kRegPowerUpReset = 0x3A;
constexpr std::uint8_t kRegInverseProductId = 0x3F;
constexpr std::uint8_t kRegMotionBurst = 0x50;
constexpr std::uint8_t kRegSromLoadBurst = 0x62;
constexpr std::uint8_t kMotionMot = 0x80;
constexpr std::uint8_t kMotionLift = 0x08;
constexpr std::size_t kSromLength = 4094;

}  // namespace

std::vector<std::uint8_t> test_srom_image() {
  // The same sequence as firmware/CMakeLists.txt: s = s * 1103515245 + 12345
  // mod 2^31 from s = 1, each byte bits 16..23 of the new s.
  std::vector<std::uint8_t> image(kSromLength);
  std::uint64_t s = 1;
  for (std::uint8_t& b : image) {
    s = (s * 1103515245u + 12345u) % 2147483648u;
    b = static_cast<std::uint8_t>((s / 65536u) % 256u);
  }
  return image;
}

Pmw33xxModel::Pmw33xxModel(Kind kind, std::vector<MotionFrame> script,
                           std::vector<std::uint8_t> srom, std::uint8_t srom_id,
                           std::uint8_t product_id, std::uint8_t idle_squal)
    : kind_(kind),
      script_(std::move(script)),
      srom_(std::move(srom)),
      srom_id_(srom_id),
      product_id_(product_id != 0 ? product_id
                                  : (kind == Kind::kPmw3360 ? kPmw3360Id : kPmw3389Id)),
      idle_squal_(idle_squal) {}

int Pmw33xxModel::cpi() const {
  if (kind_ == Kind::kPmw3360) return (config1_ + 1) * 100;
  return (config1_ << 8 | resolution_l_) * 50;
}

void Pmw33xxModel::reset_pin(bool high, double t_us) {
  if (high == nreset_high_) return;
  nreset_high_ = high;
  if (!high && selected_) violation(t_us, "NRESET pulled low while selected");
}

void Pmw33xxModel::ncs_pin(bool high, double t_us) {
  const bool select = !high;
  if (select == selected_) return;
  selected_ = select;
  if (select) {
    if (last_was_burst_ && t_us - deselect_us_ < timing_.t_bexit) {
      violation(t_us, "NCS high for less than t_BEXIT (500 ns) after a burst");
    }
    select_us_ = t_us;
    state_ = t_us >= silent_from_us_ ? State::kSilent : State::kAddress;
    return;
  }
  if (state_ == State::kReadData) {
    violation(t_us, "NCS raised between the address and the data of a read of " + hex(address_));
  }
  if (state_ == State::kWriteData) {
    violation(t_us, "NCS raised between the address and the data of a write to " + hex(address_));
  }
  if (state_ == State::kAddress && last_write_end_us_ >= select_us_ &&
      t_us - last_write_end_us_ < timing_.t_sclk_ncs_write) {
    violation(t_us, "NCS raised sooner than t_SCLK-NCS (35 us) after a write");
  }
  if (state_ == State::kSromLoad) {
    load_end_us_ = t_us;
    srom_running_ = srom_received_ == srom_;
    load_enabled_ = false;
  }
  last_was_burst_ = state_ == State::kBurst;
  deselect_us_ = t_us;
  state_ = State::kAddress;
}

std::uint8_t Pmw33xxModel::read_register(std::uint8_t address, double t_us) {
  if (address >= kRegMotion && address <= kRegMotion + 4) motion_read_[address - kRegMotion] = true;
  switch (address) {
    case kRegProductId:
      return product_id_;
    case kRegInverseProductId:
      return static_cast<std::uint8_t>(~product_id_);
    case kRegResolutionL:
      return resolution_l_;
    case kRegConfig1:
      return config1_;
    case kRegConfig2:
      return config2_;
    case kRegSromId:
      return srom_running_ ? srom_id_ : 0x00;
    case kRegDataOutLower:
    case kRegDataOutUpper:
      if (!crc_tested_) return 0x00;
      if (t_us - crc_start_us_ < timing_.t_srom_enable) {
        violation(t_us, "Data_Out read sooner than 10 ms after the CRC test started");
      }
      if (!srom_running_) return 0x00;
      return address == kRegDataOutLower ? 0xEF : 0xBE;
    case kRegMotion:
    case kRegMotion + 1:
    case kRegMotion + 2:
    case kRegMotion + 3:
    case kRegMotion + 4:
      return 0x00;
    default:
      violation(t_us, "read of register " + hex(address) + ", which the model does not have");
      return 0x00;
  }
}

void Pmw33xxModel::write_register(std::uint8_t address, std::uint8_t value, double t_us) {
  switch (address) {
    case kRegPowerUpReset:
      if (value == 0x5A) {
        reset_at_us_ = t_us;
        srom_running_ = false;
        burst_armed_ = false;
        for (bool& r : motion_read_) r = false;
      }
      return;
    case kRegConfig1:
      config1_ = value;
      return;
    case kRegResolutionL:
      if (kind_ == Kind::kPmw3360) break;
      resolution_l_ = value;
      return;
    case kRegConfig2:
      config2_ = value;
      return;
    case kRegMotionBurst:
      burst_armed_ = true;
      return;
    case kRegSromEnable:
      if (value == 0x1D) {
        for (const bool r : motion_read_) {
          if (!r) violation(t_us, "SROM download before registers 0x02..0x06 were read once");
          if (!r) break;
        }
        srom_init_us_ = t_us;
      } else if (value == 0x18) {
        if (t_us - srom_init_us_ < timing_.t_srom_enable) {
          violation(t_us, "SROM_Enable 0x18 sooner than 10 ms after 0x1D");
        }
        load_enabled_ = true;
      } else if (value == 0x15) {
        crc_tested_ = true;
        crc_start_us_ = t_us;
      } else {
        violation(t_us, "SROM_Enable written " + hex(value));
      }
      srom_enable_ = value;
      return;
    default:
      break;
  }
  violation(t_us, "write to register " + hex(address) + ", which the model does not have");
}

void Pmw33xxModel::start_burst(double t_us) {
  if (!burst_armed_) violation(t_us, "Motion_Burst read without a write to 0x50 before it");
  if (!srom_running_) violation(t_us, "Motion_Burst read with no SROM running");
  const MotionFrame f = burst_times_.size() < script_.size() ? script_[burst_times_.size()]
                                                             : MotionFrame{0, 0, idle_squal_};
  const std::int16_t dx = f.lifted ? 0 : f.dx;
  const std::int16_t dy = f.lifted ? 0 : f.dy;
  std::uint8_t motion = 0;
  if (dx != 0 || dy != 0) motion |= kMotionMot;
  if (f.lifted) motion |= kMotionLift;
  const auto u = [](std::int16_t v) { return static_cast<std::uint16_t>(v); };
  // Motion, Observation, Delta_X_L, _H, Delta_Y_L, _H, SQUAL, Raw_Data_Sum,
  // Maximum_Raw_Data, Minimum_Raw_Data, Shutter_Upper, Shutter_Lower.
  burst_ = {motion,
            0x3F,
            static_cast<std::uint8_t>(u(dx) & 0xFF),
            static_cast<std::uint8_t>(u(dx) >> 8),
            static_cast<std::uint8_t>(u(dy) & 0xFF),
            static_cast<std::uint8_t>(u(dy) >> 8),
            f.squal,
            0x80,
            0xA0,
            0x10,
            static_cast<std::uint8_t>(f.shutter >> 8),
            static_cast<std::uint8_t>(f.shutter & 0xFF)};
  burst_at_ = 0;
  burst_times_.push_back(t_us);
}

std::uint8_t Pmw33xxModel::exchange(std::uint8_t mosi, double start_us, double end_us) {
  ++accesses_;
  if (state_ == State::kSilent || start_us >= silent_from_us_) {
    state_ = State::kSilent;
    return 0xFF;
  }
  if (!nreset_high_) violation(start_us, "SPI access while NRESET is low");
  const double previous_end = last_byte_end_us_;
  last_byte_end_us_ = end_us;
  switch (state_) {
    case State::kAddress: {
      const bool write = (mosi & 0x80) != 0;
      address_ = static_cast<std::uint8_t>(mosi & 0x7f);
      address_end_us_ = end_us;
      const bool is_reset = write && address_ == kRegPowerUpReset;
      if (reset_at_us_ < 0.0 && !is_reset) {
        violation(start_us, "access to " + hex(address_) + " before the Power_Up_Reset write");
      }
      if (reset_at_us_ >= 0.0 && start_us - reset_at_us_ < timing_.t_power_up) {
        violation(start_us, "access sooner than 50 ms after Power_Up_Reset");
      }
      if (start_us - last_write_end_us_ < timing_.t_sww) {
        violation(start_us, "command sooner than t_SWW/t_SWR (180 us) after a write");
      }
      if (start_us - last_read_end_us_ < timing_.t_srr) {
        violation(start_us, "command sooner than t_SRR/t_SRW (20 us) after a read");
      }
      if (start_us - load_end_us_ < timing_.t_load_exit) {
        violation(start_us, "access sooner than 200 us after the SROM download");
      }
      if (write && address_ == kRegSromLoadBurst) {
        if (!load_enabled_) violation(start_us, "SROM_Load_Burst without SROM_Enable 0x18");
        srom_received_.clear();
        state_ = State::kSromLoad;
      } else if (write) {
        state_ = State::kWriteData;
      } else if (address_ == kRegMotionBurst) {
        state_ = State::kBurst;
        start_burst(start_us);
      } else {
        // Any other register access ends burst mode until 0x50 is written.
        burst_armed_ = false;
        state_ = State::kReadData;
      }
      return 0;
    }
    case State::kReadData: {
      if (start_us - address_end_us_ < timing_.t_srad) {
        violation(start_us, "data of " + hex(address_) + " read sooner than t_SRAD (160 us)");
      }
      state_ = State::kAddress;
      last_read_end_us_ = end_us;
      return read_register(address_, start_us);
    }
    case State::kWriteData:
      write_register(address_, mosi, start_us);
      last_write_end_us_ = end_us;
      state_ = State::kAddress;
      return 0;
    case State::kSromLoad:
      if (start_us - previous_end < timing_.t_load_byte) {
        violation(start_us, "SROM byte sooner than 15 us after the one before");
      }
      srom_received_.push_back(mosi);
      return 0;
    case State::kBurst:
      if (burst_at_ == 0 && start_us - address_end_us_ < timing_.t_srad_motbr) {
        violation(start_us, "burst data read sooner than t_SRAD_MOTBR (35 us) after 0x50");
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
