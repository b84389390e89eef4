#include "mpu6050_model.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

namespace moa::firmware_sim {

Mpu6050Model::Mpu6050Model(Rate rate, std::uint8_t who_am_i) : rate_(std::move(rate)) {
  registers_[kRegWhoAmI] = who_am_i;
  registers_[kRegPwrMgmt1] = 0x40;  // reset value: asleep
}

bool Mpu6050Model::address(std::uint8_t address_byte) {
  selected_ = (address_byte >> 1) == kAddress;
  reading_ = (address_byte & 1u) != 0;
  pointer_set_ = false;
  return selected_;
}

bool Mpu6050Model::write(std::uint8_t byte) {
  if (!selected_ || reading_) return false;
  if (!pointer_set_) {
    pointer_ = byte & 0x7F;
    pointer_set_ = true;
    return true;
  }
  writes_.push_back({pointer_, byte});
  // WHO_AM_I and the data registers are read-only.
  if (pointer_ != kRegWhoAmI && (pointer_ < 0x3B || pointer_ > 0x48)) registers_[pointer_] = byte;
  pointer_ = static_cast<std::uint8_t>((pointer_ + 1) & 0x7F);
  return true;
}

std::uint8_t Mpu6050Model::read(double t_us) {
  if (!selected_ || !reading_) return 0xFF;
  std::uint8_t value = registers_[pointer_];
  if (pointer_ == kRegGyroZoutH) {
    // A sleeping chip does not sample: its outputs keep their reset value 0.
    latched_ = asleep() ? std::int16_t{0} : raw_of(rate_(t_us));
    samples_.push_back({t_us, latched_});
    value = static_cast<std::uint8_t>(static_cast<std::uint16_t>(latched_) >> 8);
  } else if (pointer_ == kRegGyroZoutL) {
    value = static_cast<std::uint8_t>(static_cast<std::uint16_t>(latched_) & 0xFF);
  }
  pointer_ = static_cast<std::uint8_t>((pointer_ + 1) & 0x7F);
  return value;
}

void Mpu6050Model::stop() { selected_ = false; }

double Mpu6050Model::lsb_per_dps() const {
  static constexpr double kSensitivity[4] = {131.0, 65.5, 32.8, 16.4};
  return kSensitivity[(registers_[kRegGyroConfig] >> 3) & 0x03];
}

std::int16_t Mpu6050Model::raw_of(double rate) const {
  const double lsb = std::round(rate * 180.0 / std::numbers::pi * lsb_per_dps());
  return static_cast<std::int16_t>(std::clamp(lsb, -32768.0, 32767.0));
}

}  // namespace moa::firmware_sim
