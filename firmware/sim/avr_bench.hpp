// The firmware under simavr: an AVR running the firmware ELF, ADNS-3080
// models on its SPI bus (one per chip select), the RESET line, and the
// UART captured byte by byte with its time.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mpu6050_model.hpp"
#include "spi_chip.hpp"

struct avr_t;
struct avr_irq_t;

namespace moa::firmware_sim {

struct McuRegisters;

/// One firmware build as CMake made it (firmware/CMakeLists.txt).
struct FirmwareBuild {
  std::string name;
  std::string elf;
  std::string mcu;  ///< simavr core name, e.g. "atmega328p"
  std::uint32_t f_cpu = 0;
  int sensors = 0;
  int k = 0;
  int frame_hz = 0;
  int cpi = 0;
  std::uint32_t baud = 0;
  std::string sensor;  ///< ADNS3080, PMW3360, PMW3389, PMW3901 or PAA5100
};

/// The documented pinout (docs/firmware.md): chip select of sensor i.
struct Pin {
  char port;
  int bit;
};
inline constexpr int kMaxChipSelects = 14;
inline constexpr Pin kChipSelects[kMaxChipSelects] = {
    {'B', 2}, {'B', 1}, {'B', 0}, {'D', 7}, {'D', 6}, {'D', 5}, {'D', 4},
    {'D', 3}, {'C', 0}, {'C', 1}, {'C', 2}, {'C', 3}, {'C', 4}, {'C', 5}};
inline constexpr Pin kSensorReset = {'D', 2};

class AvrBench {
 public:
  struct UartByte {
    std::uint8_t value;
    double t_us;
  };

  /// `sensors[i]` answers on chip select i; a null entry leaves that
  /// select unconnected (MISO then reads 0xFF, as an undriven line with a
  /// pull-up would).
  /// Throws std::runtime_error if the ELF or the MCU cannot be loaded.
  AvrBench(const FirmwareBuild& build, std::vector<std::unique_ptr<SpiChip>> sensors);
  ~AvrBench();
  AvrBench(const AvrBench&) = delete;
  AvrBench& operator=(const AvrBench&) = delete;

  /// Runs the AVR until simulated time `t_us`; throws if the core stops.
  void run_until_us(double t_us);
  double now_us() const;

  /// Bytes to the firmware's RXD.
  void send(const std::vector<std::uint8_t>& bytes);
  /// Everything the firmware sent on TXD so far.
  const std::vector<UartByte>& uart() const { return uart_; }

  SpiChip* sensor(std::size_t i) { return i < sensors_.size() ? sensors_[i].get() : nullptr; }
  /// The chip on select i as the model it is, or null.
  template <class Model>
  Model* model(std::size_t i) {
    return dynamic_cast<Model*>(sensor(i));
  }
  /// Puts `gyro` on the TWI bus (SDA PC4, SCL PC5); before the first
  /// run_until_us, so that the firmware finds it at start. Without one the
  /// bus has no device: every address goes unacknowledged.
  void attach_gyro(std::unique_ptr<Mpu6050Model> gyro);
  Mpu6050Model* gyro() { return gyro_.get(); }
  /// TWCR writes the firmware made while the gyro held the bus.
  std::size_t twcr_writes_while_held() const { return twcr_writes_held_; }
  /// Bus-level faults (several sensors selected, wrong SPI mode or clock).
  const std::vector<std::string>& violations() const { return violations_; }
  /// When the firmware started Timer1 (its timestamp epoch), or -1.
  double clock_start_us() const { return clock_start_us_; }
  /// Longest span, microseconds, from the first chip select going low to
  /// the last going high among one frame's motion bursts: the time the
  /// reads of one frame take.
  double longest_frame_read_us() const { return longest_read_us_; }

 private:
  struct PinHook {
    AvrBench* bench;
    int index;  ///< chip select index, or -1 for RESET
  };

  void wire();
  void release();
  static void on_spdr_write(avr_t* avr, std::uint16_t address, std::uint8_t value, void* param);
  static std::uint64_t on_spi_done(avr_t* avr, std::uint64_t when, void* param);
  static void on_uart(avr_irq_t* irq, std::uint32_t value, void* param);
  static void on_tccr1b(avr_irq_t* irq, std::uint32_t value, void* param);
  static void on_pin(avr_irq_t* irq, std::uint32_t value, void* param);
  static void on_twi(avr_irq_t* irq, std::uint32_t value, void* param);
  static void on_twi_status(avr_irq_t* irq, std::uint32_t value, void* param);
  static void on_twcr_write(avr_t* avr, std::uint16_t address, std::uint8_t value, void* param);
  void twi_message(std::uint32_t value);
  int sclk_divider() const;
  void spdr_written(std::uint8_t mosi);
  void spi_done();
  void pin_changed(int index, bool high);

  FirmwareBuild build_;
  avr_t* avr_ = nullptr;
  const McuRegisters* mcu_ = nullptr;
  avr_irq_t* spi_in_ = nullptr;
  std::uint8_t spi_mosi_ = 0;
  double spi_start_us_ = 0.0;
  avr_irq_t* uart_in_ = nullptr;
  std::vector<std::unique_ptr<SpiChip>> sensors_;
  std::unique_ptr<Mpu6050Model> gyro_;
  avr_irq_t* twi_in_ = nullptr;
  bool twi_after_address_write_ = false;  ///< the last TWI step sent SLA+W
  std::size_t twcr_writes_held_ = 0;
  // simavr's own TWCR write handler, which the bench's wraps.
  void (*twcr_write_)(avr_t*, std::uint16_t, std::uint8_t, void*) = nullptr;
  void* twcr_param_ = nullptr;
  std::vector<PinHook> hooks_;
  bool cs_high_[kMaxChipSelects];
  std::vector<void*> elf_memory_;  ///< the ELF symbol table, malloc'ed by simavr
  std::vector<UartByte> uart_;
  std::vector<std::string> violations_;
  // Frame read time: a span of burst selections with short gaps.
  double span_start_us_ = 0.0;
  double last_deselect_us_ = -1e9;
  std::size_t bursts_at_select_ = 0;
  double longest_read_us_ = 0.0;
  double clock_start_us_ = -1.0;
};

}  // namespace moa::firmware_sim
