// A chip on the simulated SPI bus (one per chip select): the pins the bench
// drives, the bytes it clocks, and the data-sheet rules the master broke.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace moa::firmware_sim {

class SpiChip {
 public:
  virtual ~SpiChip() = default;
  /// The shared reset line PD2 (ADNS-3080 RESET, active high; a PMW part's
  /// NRESET, active low).
  virtual void reset_pin(bool high, double t_us) = 0;
  /// NCS pin level (active low).
  virtual void ncs_pin(bool high, double t_us) = 0;
  /// One SPI byte while selected, clocked from `start_us` to `end_us`:
  /// `mosi` from the master; returns what the chip shifted out meanwhile.
  virtual std::uint8_t exchange(std::uint8_t mosi, double start_us, double end_us) = 0;

  /// Motion bursts served.
  std::size_t bursts() const { return burst_times_.size(); }
  /// Start of the address byte of each burst, microseconds.
  const std::vector<double>& burst_times() const { return burst_times_; }
  /// SPI bytes exchanged.
  std::size_t accesses() const { return accesses_; }
  /// Data-sheet rules the master broke, one line each (empty when none).
  const std::vector<std::string>& violations() const { return violations_; }

 protected:
  void violation(double t_us, const std::string& what);
  static std::string hex(std::uint8_t value);

  std::vector<double> burst_times_;
  std::size_t accesses_ = 0;
  std::vector<std::string> violations_;
};

/// What one motion burst reports (one sensor frame).
struct MotionFrame {
  std::int16_t dx = 0;
  std::int16_t dy = 0;
  std::uint8_t squal = 100;
  bool overflow = false;           ///< ADNS-3080 Motion bit 4 (OVF)
  bool lifted = false;             ///< PMW33xx Motion bit 3 (Lift_Stat)
  std::uint16_t shutter = 0x0100;  ///< PMW parts' Shutter_Upper:Lower
};

}  // namespace moa::firmware_sim
