// A simulated PixArt PMW3360 or PMW3389 on the SPI bus: power-up reset,
// the SROM download handshake and its CRC test, the registers the firmware
// uses, 12-byte motion bursts that play a script, and the serial port
// timing of the data sheet checked on every access (firmware/src/pmw33xx.h
// lists the figures).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "spi_chip.hpp"

namespace moa::firmware_sim {

/// PMW3360 data sheet v1.50 (the PMW3389's is the same here), microseconds.
struct Pmw33xxTiming {
  double t_srad = 160.0;           ///< read: address byte to data byte
  double t_srad_motbr = 35.0;      ///< Motion_Burst: address to the first data byte
  double t_sww = 180.0;            ///< after a write, before the next command (t_SWW, t_SWR)
  double t_srr = 20.0;             ///< after a read, before the next command (t_SRR, t_SRW)
  double t_sclk_ncs_write = 35.0;  ///< last bit of a write to NCS high
  double t_bexit = 0.5;            ///< NCS high after a burst
  double t_power_up = 50000.0;     ///< Power_Up_Reset to the first access
  double t_srom_enable = 10000.0;  ///< SROM_Enable 0x1D to 0x18; 0x15 to Data_Out
  double t_load_byte = 15.0;       ///< between bytes of SROM_Load_Burst
  double t_load_exit = 200.0;      ///< NCS high after the load, before the next access
};

/// The made-up image the firmware tests upload (firmware/CMakeLists.txt
/// makes the same bytes): 4094 bytes of a linear congruential sequence.
std::vector<std::uint8_t> test_srom_image();
inline constexpr std::uint8_t kTestSromId = 0xA5;

class Pmw33xxModel : public SpiChip {
 public:
  enum class Kind { kPmw3360, kPmw3389 };
  static constexpr std::uint8_t kPmw3360Id = 0x42;
  static constexpr std::uint8_t kPmw3389Id = 0x47;

  /// Bursts play `script`, then report no motion at `idle_squal`. The chip
  /// takes an upload equal to `srom` (then SROM_ID reads `srom_id` and the
  /// CRC test 0xBEEF); any other upload leaves SROM_ID at 0.
  /// `product_id` 0 means the kind's own.
  Pmw33xxModel(Kind kind, std::vector<MotionFrame> script, std::vector<std::uint8_t> srom,
               std::uint8_t srom_id, std::uint8_t product_id = 0, std::uint8_t idle_squal = 100);

  void reset_pin(bool high, double t_us) override;
  void ncs_pin(bool high, double t_us) override;
  std::uint8_t exchange(std::uint8_t mosi, double start_us, double end_us) override;

  /// From `t_us` on the chip drives nothing: MISO reads 0xFF.
  void stop_answering_from(double t_us) { silent_from_us_ = t_us; }

  bool srom_running() const { return srom_running_; }
  std::size_t srom_bytes() const { return srom_received_.size(); }
  bool crc_tested() const { return crc_tested_; }
  /// The resolution the registers hold, counts per inch.
  int cpi() const;
  std::uint8_t config2() const { return config2_; }
  bool power_up_reset_seen() const { return reset_at_us_ >= 0.0; }

 private:
  enum class State { kAddress, kReadData, kWriteData, kBurst, kSromLoad, kSilent };

  std::uint8_t read_register(std::uint8_t address, double t_us);
  void write_register(std::uint8_t address, std::uint8_t value, double t_us);
  void start_burst(double t_us);

  Kind kind_;
  std::vector<MotionFrame> script_;
  std::vector<std::uint8_t> srom_;
  std::uint8_t srom_id_;
  std::uint8_t product_id_;
  std::uint8_t idle_squal_;
  Pmw33xxTiming timing_;
  double silent_from_us_ = 1e300;

  bool nreset_high_ = true;
  bool selected_ = false;
  double select_us_ = 0.0;
  double deselect_us_ = -1e9;
  bool last_was_burst_ = false;
  double reset_at_us_ = -1.0;
  bool motion_read_[5] = {false, false, false, false, false};  ///< 0x02..0x06 after reset
  double last_write_end_us_ = -1e9;
  double last_read_end_us_ = -1e9;
  bool burst_armed_ = false;

  State state_ = State::kAddress;
  std::uint8_t address_ = 0;
  double address_end_us_ = 0.0;
  double last_byte_end_us_ = 0.0;

  std::uint8_t config1_ = 0x0F;       ///< PMW3360 reset value: 1600 cpi
  std::uint8_t resolution_l_ = 0x20;  ///< PMW3389: 0x0020 x 50 = 1600 cpi
  std::uint8_t config2_ = 0x20;
  std::uint8_t srom_enable_ = 0;
  double srom_init_us_ = -1e9;
  bool load_enabled_ = false;
  std::vector<std::uint8_t> srom_received_;
  double load_end_us_ = -1e9;
  bool srom_running_ = false;
  bool crc_tested_ = false;
  double crc_start_us_ = -1e9;

  std::vector<std::uint8_t> burst_;
  std::size_t burst_at_ = 0;
};

}  // namespace moa::firmware_sim
