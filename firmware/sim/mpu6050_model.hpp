// A simulated MPU-6050 class gyro on the TWI (I2C) bus of the simulated
// AVR: the registers the firmware uses, a z rate that follows a programmed
// function of time, and a bus that can be made to hang.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

namespace moa::firmware_sim {

class Mpu6050Model {
 public:
  static constexpr std::uint8_t kAddress = 0x68;  ///< 7 bits, AD0 low
  static constexpr std::uint8_t kWhoAmI = 0x68;
  static constexpr std::uint8_t kRegGyroConfig = 0x1B;
  static constexpr std::uint8_t kRegConfig = 0x1A;
  static constexpr std::uint8_t kRegGyroZoutH = 0x47;
  static constexpr std::uint8_t kRegGyroZoutL = 0x48;
  static constexpr std::uint8_t kRegPwrMgmt1 = 0x6B;
  static constexpr std::uint8_t kRegWhoAmI = 0x75;

  /// rad/s about the chip's z axis, counter-clockwise positive (right hand,
  /// z up), at simulated time t (microseconds).
  using Rate = std::function<double(double t_us)>;

  /// One GYRO_ZOUT read: when, and the raw value the chip gave.
  struct Sample {
    double t_us;
    std::int16_t raw;
  };

  explicit Mpu6050Model(Rate rate, std::uint8_t who_am_i = kWhoAmI);

  /// Bus events, as the master sends them. `address_byte`: 7-bit address
  /// and R/W bit after a START or repeated START; true when this chip
  /// acknowledges (its address).
  bool address(std::uint8_t address_byte);
  /// A byte written to the chip while addressed; true: acknowledged.
  bool write(std::uint8_t byte);
  /// A byte read from the chip while addressed, at time `t_us`.
  std::uint8_t read(double t_us);
  void stop();

  /// From `t_us` on the chip holds SCL low: no transfer step completes.
  void hold_bus_from(double t_us) { hold_from_us_ = t_us; }
  bool bus_held(double t_us) const { return t_us >= hold_from_us_; }

  /// LSB per deg/s at the full scale GYRO_CONFIG selects (FS_SEL 0..3:
  /// 131, 65.5, 32.8, 16.4; register map, gyroscope sensitivity).
  double lsb_per_dps() const;
  /// The raw output for `rate` rad/s: rounded, saturated to int16.
  std::int16_t raw_of(double rate) const;
  std::uint8_t register_value(std::uint8_t reg) const { return registers_[reg & 0x7F]; }
  bool asleep() const { return (registers_[kRegPwrMgmt1] & 0x40) != 0; }
  const std::vector<Sample>& samples() const { return samples_; }
  /// Register writes, in order, as (register, value).
  const std::vector<std::array<std::uint8_t, 2>>& writes() const { return writes_; }

 private:
  Rate rate_;
  std::array<std::uint8_t, 128> registers_{};
  bool selected_ = false;
  bool reading_ = false;
  bool pointer_set_ = false;  ///< the first byte of a write sets the register pointer
  std::uint8_t pointer_ = 0;
  std::int16_t latched_ = 0;  ///< ZOUT_H and ZOUT_L of one burst are one sample
  double hold_from_us_ = 1e300;
  std::vector<Sample> samples_;
  std::vector<std::array<std::uint8_t, 2>> writes_;
};

}  // namespace moa::firmware_sim
