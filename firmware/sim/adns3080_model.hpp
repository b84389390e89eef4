// A simulated ADNS-3080 on the SPI bus of the simulated AVR: the registers
// the firmware uses, motion bursts that play a script, and the serial
// port timing of the data sheet checked on every access.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "spi_chip.hpp"

namespace moa::firmware_sim {

/// ADNS-3080 serial port timing (Avago data sheet), microseconds.
struct Adns3080Timing {
  double t_srad = 50.0;      ///< read: address byte to data byte
  double t_srad_mot = 75.0;  ///< the same for Motion (0x02) and Motion_Burst (0x50)
  double t_sww = 50.0;       ///< after a write, before the next command (t_SWW, t_SWR)
  double t_bexit = 4.0;      ///< NCS high to leave burst mode
  double t_reset = 10.0;     ///< shortest RESET pulse
};

/// Its MotionFrame counts must fit 8 bits (Delta_X, Delta_Y).
class Adns3080Model : public SpiChip {
 public:
  static constexpr std::uint8_t kProductId = 0x17;
  static constexpr std::uint8_t kConfigurationReset = 0x09;

  /// Bursts play `script` in order, then report no motion at `idle_squal`.
  explicit Adns3080Model(std::vector<MotionFrame> script, std::uint8_t product_id = kProductId,
                         std::uint8_t idle_squal = 100);

  /// RESET pin level (active high); a falling edge after a long enough
  /// pulse resets the registers.
  void reset_pin(bool high, double t_us) override;
  void ncs_pin(bool high, double t_us) override;
  std::uint8_t exchange(std::uint8_t mosi, double start_us, double end_us) override;

  std::uint8_t configuration() const { return configuration_; }

 private:
  enum class State { kAddress, kReadData, kWriteData, kBurst };

  std::uint8_t read_register(std::uint8_t address) const;

  std::vector<MotionFrame> script_;
  std::uint8_t product_id_;
  std::uint8_t idle_squal_;
  Adns3080Timing timing_;

  bool was_reset_ = false;
  bool reset_high_ = false;
  double reset_rise_us_ = 0.0;
  bool selected_ = false;
  double deselect_us_ = -1e9;
  bool last_was_burst_ = false;
  double last_write_end_us_ = -1e9;

  State state_ = State::kAddress;
  std::uint8_t address_ = 0;
  double address_end_us_ = 0.0;
  std::uint8_t configuration_ = kConfigurationReset;
  std::vector<std::uint8_t> burst_;
  std::size_t burst_at_ = 0;
};

}  // namespace moa::firmware_sim
