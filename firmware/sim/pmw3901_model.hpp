// A simulated PixArt PMW3901MB or PAA5100JE-Q on the SPI bus: power-up
// reset, the banked registers of the init sequence (every write recorded
// for the tests to compare with PixArt's sequence), the trim registers the
// sequence reads, 12-byte motion bursts that play a script, and the serial
// port timing (firmware/src/pmw3901.h) checked on every access.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "spi_chip.hpp"

namespace moa::firmware_sim {

/// PMW3901MB data sheet, AC table, microseconds.
struct Pmw3901Timing {
  double t_srad = 35.0;        ///< read (and Motion_Burst): address to data
  double t_sww = 45.0;         ///< after a write, before the next command (t_SWW, t_SWR)
  double t_srr = 20.0;         ///< after a read, before the next command (t_SRR, t_SRW)
  double t_power_up = 1000.0;  ///< Power_Up_Reset to the first access
};

/// What the chip answers for registers 0x67, 0x70, 0x71, 0x73 of bank
/// 0x0E (the reads of the init sequence).
struct Pmw3901Trim {
  std::uint8_t r67 = 0x80;
  std::uint8_t r70 = 20;
  std::uint8_t r71 = 100;
  std::uint8_t r73 = 0x00;
};

class Pmw3901Model : public SpiChip {
 public:
  static constexpr std::uint8_t kProductId = 0x49;

  struct Write {
    std::uint8_t bank;  ///< the value of 0x7F when written (0x7F writes: the old bank)
    std::uint8_t reg;
    std::uint8_t value;
    double t_us;
  };

  using Trim = Pmw3901Trim;

  explicit Pmw3901Model(std::vector<MotionFrame> script, Trim trim = {},
                        std::uint8_t product_id = kProductId, std::uint8_t idle_squal = 100);

  void reset_pin(bool high, double t_us) override;
  void ncs_pin(bool high, double t_us) override;
  std::uint8_t exchange(std::uint8_t mosi, double start_us, double end_us) override;

  void stop_answering_from(double t_us) { silent_from_us_ = t_us; }
  /// Every register write after the Power_Up_Reset, in order.
  const std::vector<Write>& writes() const { return writes_; }
  bool power_up_reset_seen() const { return reset_at_us_ >= 0.0; }

 private:
  enum class State { kAddress, kReadData, kWriteData, kBurst, kSilent };

  std::uint8_t read_register(std::uint8_t address, double t_us);
  void start_burst(double t_us);

  std::vector<MotionFrame> script_;
  Trim trim_;
  std::uint8_t product_id_;
  std::uint8_t idle_squal_;
  Pmw3901Timing timing_;
  double silent_from_us_ = 1e300;

  bool nreset_high_ = true;
  bool selected_ = false;
  double reset_at_us_ = -1.0;
  bool motion_read_[5] = {false, false, false, false, false};
  double last_write_end_us_ = -1e9;
  double last_read_end_us_ = -1e9;
  std::uint8_t bank_ = 0;

  State state_ = State::kAddress;
  std::uint8_t address_ = 0;
  double address_end_us_ = 0.0;
  std::vector<Write> writes_;
  std::vector<std::uint8_t> burst_;
  std::size_t burst_at_ = 0;
};

}  // namespace moa::firmware_sim
