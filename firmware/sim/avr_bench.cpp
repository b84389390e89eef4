#include "avr_bench.hpp"

extern "C" {
#include <avr_ioport.h>
#include <avr_spi.h>
#include <avr_twi.h>
#include <avr_uart.h>
#include <sim_avr.h>
#include <sim_elf.h>
#include <sim_io.h>
#include <sim_irq.h>
}

#include <algorithm>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <utility>

// simavr 1.6's avr_terminate() leaves its IRQ tables, IRQ hooks and a
// buffer of the EEPROM module allocated; LeakSanitizer (the sanitizer CI
// build) would fail every test on them. Only allocations made inside
// libsimavr are excused; the bench's own are still checked.
extern "C" const char* __lsan_default_suppressions() { return "leak:libsimavr.so\n"; }

namespace moa::firmware_sim {

// Registers (data-space addresses) of the MCUs the firmware supports:
// ATmega328P and ATmega8 data sheets, register summary.
struct McuRegisters {
  const char* mcu;
  std::uint16_t spcr;
  std::uint16_t spsr;
  std::uint16_t spdr;
  std::uint16_t tccr1b;
  std::uint16_t twsr;
  std::uint16_t twcr;
};

namespace {

constexpr McuRegisters kMcuRegisters[] = {{"atmega328p", 0x4C, 0x4D, 0x4E, 0x81, 0xB9, 0xBC},
                                          {"atmega8", 0x2D, 0x2E, 0x2F, 0x4E, 0x21, 0x56}};
constexpr std::uint8_t kTwint = 1u << 7;
constexpr std::uint8_t kTimerClockSelect = 0x07;  // CS12:0 in TCCR1B
constexpr std::uint8_t kSpif = 1u << 7;

constexpr std::uint8_t kSpe = 1u << 6;
constexpr std::uint8_t kDord = 1u << 5;
constexpr std::uint8_t kMstr = 1u << 4;
constexpr std::uint8_t kCpol = 1u << 3;
constexpr std::uint8_t kCpha = 1u << 2;
constexpr std::uint8_t kSpi2x = 1u << 0;
constexpr double kMaxSclkHz = 2e6;  // f_SCLK of the ADNS-3080, PMW3360/3389, PMW3901/PAA5100
// Chip-select gaps inside one frame's reads are t_BEXIT plus the summing
// of one sensor (about 20 us at 8 MHz); frames are hundreds of
// microseconds apart.
constexpr double kFrameGapUs = 100.0;

// simavr's log lines (configuration chatter) would bury the test output.
extern "C" void quiet_logger(avr_t*, const int level, const char* format, va_list ap) {
  if (level > LOG_ERROR) return;
  std::vfprintf(stderr, format, ap);
}

// In raw mode simavr sleeps in real time while the AVR sleeps; the tests
// want simulated time only.
extern "C" void no_sleep(avr_t*, avr_cycle_count_t) {}

avr_irq_t* get_irq(avr_t* avr, std::uint32_t ioctl, int index, const char* what) {
  avr_irq_t* irq = avr_io_getirq(avr, ioctl, index);
  if (irq == nullptr) throw std::runtime_error(std::string("simavr: no IRQ for ") + what);
  return irq;
}

}  // namespace

AvrBench::AvrBench(const FirmwareBuild& build, std::vector<std::unique_ptr<SpiChip>> sensors)
    : build_(build), sensors_(std::move(sensors)) {
  if (sensors_.size() > kMaxChipSelects) throw std::runtime_error("more sensors than chip selects");
  for (const McuRegisters& r : kMcuRegisters) {
    if (build_.mcu == r.mcu) mcu_ = &r;
  }
  if (mcu_ == nullptr) throw std::runtime_error("no register map for " + build_.mcu);
  std::fill(std::begin(cs_high_), std::end(cs_high_), true);
  avr_global_logger_set(quiet_logger);

  elf_firmware_t firmware;
  std::memset(&firmware, 0, sizeof firmware);
  if (elf_read_firmware(build_.elf.c_str(), &firmware) != 0) {
    throw std::runtime_error("simavr: cannot read " + build_.elf);
  }
  // The core copies the memories; the symbol table is freed with the
  // bench, after the core (a tracing build of simavr refers to it).
  for (std::uint32_t i = 0; i < firmware.symbolcount; ++i)
    elf_memory_.push_back(firmware.symbol[i]);
  elf_memory_.push_back(firmware.symbol);
  avr_ = avr_make_mcu_by_name(build_.mcu.c_str());
  if (avr_ != nullptr) {
    avr_init(avr_);
    avr_load_firmware(avr_, &firmware);
  }
  std::free(firmware.flash);
  std::free(firmware.eeprom);
  std::free(firmware.fuse);
  std::free(firmware.lockbits);
  try {
    if (avr_ == nullptr) throw std::runtime_error("simavr: no core " + build_.mcu);
    wire();
  } catch (...) {
    release();
    throw;
  }
}

void AvrBench::wire() {
  avr_->frequency = build_.f_cpu;
  avr_->sleep = no_sleep;
  avr_->log = LOG_ERROR;

  std::uint32_t uart_flags = 0;  // no stdio echo, no polling sleeps
  avr_ioctl(avr_, AVR_IOCTL_UART_SET_FLAGS('0'), &uart_flags);
  uart_in_ = get_irq(avr_, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT, "UART input");
  avr_irq_register_notify(get_irq(avr_, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT, "UART output"),
                          on_uart, this);

  avr_irq_register_notify(avr_iomem_getirq(avr_, mcu_->tccr1b, nullptr, AVR_IOMEM_IRQ_ALL),
                          on_tccr1b, this);
  // simavr 1.6 completes every SPI byte 100 us after SPDR is written,
  // whatever the clock: 25 times too slow at 2 MHz, which would hide the
  // firmware's real frame timing. The write handler of SPDR is replaced by
  // one that completes the byte after 8 SCLK periods of the configured
  // divider; completion goes through simavr's SPI input (data + SPIF).
  spi_in_ = get_irq(avr_, AVR_IOCTL_SPI_GETIRQ(0), SPI_IRQ_INPUT, "SPI input");
  avr_->io[AVR_DATA_TO_IO(mcu_->spdr)].w.c = on_spdr_write;
  avr_->io[AVR_DATA_TO_IO(mcu_->spdr)].w.param = this;

  // The TWI bus (the gyro, if one is attached).
  twi_in_ = get_irq(avr_, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_INPUT, "TWI input");
  avr_irq_register_notify(get_irq(avr_, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_OUTPUT, "TWI output"),
                          on_twi, this);
  // simavr 1.6 reports an acknowledged SLA+W as 0x28 (data sent, ACK)
  // instead of the data sheet's 0x18; the status is put right as simavr
  // sets it, before the firmware can see TWINT.
  avr_irq_register_notify(get_irq(avr_, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_STATUS, "TWI status"),
                          on_twi_status, this);
  // TWCR writes pass through the bench: TWINT cleared as the hardware
  // does, and a held bus: writes go to the register but start nothing, so
  // TWINT never rises again (the firmware's timeout must end the wait).
  auto& io = avr_->io[AVR_DATA_TO_IO(mcu_->twcr)];
  twcr_write_ = io.w.c;
  twcr_param_ = io.w.param;
  if (twcr_write_ == nullptr) throw std::runtime_error("simavr: no TWI on " + build_.mcu);
  io.w.c = on_twcr_write;
  io.w.param = this;

  hooks_.reserve(kMaxChipSelects + 1);
  for (int i = 0; i < kMaxChipSelects; ++i) {
    hooks_.push_back(PinHook{this, i});
    avr_irq_register_notify(get_irq(avr_, AVR_IOCTL_IOPORT_GETIRQ(kChipSelects[i].port),
                                    kChipSelects[i].bit, "chip select"),
                            on_pin, &hooks_.back());
  }
  hooks_.push_back(PinHook{this, -1});
  avr_irq_register_notify(
      get_irq(avr_, AVR_IOCTL_IOPORT_GETIRQ(kSensorReset.port), kSensorReset.bit, "RESET"), on_pin,
      &hooks_.back());
}

void AvrBench::attach_gyro(std::unique_ptr<Mpu6050Model> gyro) {
  if (avr_->cycle != 0) throw std::runtime_error("attach_gyro: the AVR has run already");
  gyro_ = std::move(gyro);
}

void AvrBench::on_twcr_write(avr_t* avr, std::uint16_t address, std::uint8_t value, void* param) {
  auto* bench = static_cast<AvrBench*>(param);
  if (bench->gyro_ && bench->gyro_->bus_held(bench->now_us())) {
    // Writing 1 to TWINT clears it; nothing sets it again.
    avr->data[address] = static_cast<std::uint8_t>(value & ~kTwint);
    ++bench->twcr_writes_held_;
    return;
  }
  bench->twcr_write_(avr, address, value, bench->twcr_param_);
  // Writing one to TWINT clears it (data sheet); simavr 1.6 leaves it set
  // (its TWI vector is "sticky"), so the next wait would end at once. Its
  // handler has seen the flag by now; simavr sets TWINT only from timers.
  if (value & kTwint) avr->data[address] = static_cast<std::uint8_t>(avr->data[address] & ~kTwint);
}

void AvrBench::on_twi_status(avr_irq_t*, std::uint32_t value, void* param) {
  auto* bench = static_cast<AvrBench*>(param);
  constexpr std::uint8_t kMtDataAck = 0x28;
  constexpr std::uint8_t kMtSlaAck = 0x18;
  if (value == kMtDataAck && bench->twi_after_address_write_) {
    std::uint8_t& twsr = bench->avr_->data[bench->mcu_->twsr];
    twsr = static_cast<std::uint8_t>((twsr & 0x07) | kMtSlaAck);
  }
  bench->twi_after_address_write_ = false;
}

void AvrBench::on_twi(avr_irq_t*, std::uint32_t value, void* param) {
  static_cast<AvrBench*>(param)->twi_message(value);
}

// simavr's TWI master announces each step on TWI_IRQ_OUTPUT and expects the
// slave's answer at once on TWI_IRQ_INPUT: an ACK for its address or a
// written byte, the data for a read. No answer reads as a NACK.
void AvrBench::twi_message(std::uint32_t value) {
  avr_twi_msg_irq_t m;
  m.u.v = value;
  const std::uint8_t msg = m.u.twi.msg;
  const std::uint8_t addr = m.u.twi.addr;
  if (!gyro_) return;  // nobody on the bus: no acknowledge
  if (msg & TWI_COND_STOP) gyro_->stop();
  twi_after_address_write_ = (msg & TWI_COND_START) != 0 && (addr & 1u) == 0;
  if (msg & TWI_COND_START) {
    if (gyro_->address(addr)) avr_raise_irq(twi_in_, avr_twi_irq_msg(TWI_COND_ACK, addr, 1));
  } else if (msg & TWI_COND_WRITE) {
    if (gyro_->write(m.u.twi.data)) avr_raise_irq(twi_in_, avr_twi_irq_msg(TWI_COND_ACK, addr, 1));
  } else if (msg & TWI_COND_READ) {
    avr_raise_irq(twi_in_, avr_twi_irq_msg(TWI_COND_READ, addr, gyro_->read(now_us())));
  }
}

void AvrBench::release() {
  if (avr_ != nullptr) {
    avr_terminate(avr_);
    std::free(avr_);
    avr_ = nullptr;
  }
  for (void* p : elf_memory_) std::free(p);
  elf_memory_.clear();
}

AvrBench::~AvrBench() { release(); }

double AvrBench::now_us() const {
  return static_cast<double>(avr_->cycle) * 1e6 / static_cast<double>(build_.f_cpu);
}

void AvrBench::run_until_us(double t_us) {
  const auto target =
      static_cast<avr_cycle_count_t>(t_us * static_cast<double>(build_.f_cpu) / 1e6);
  while (avr_->cycle < target) {
    const int state = avr_run(avr_);
    if (state == cpu_Done || state == cpu_Crashed) {
      throw std::runtime_error("simavr: the AVR core stopped (state " + std::to_string(state) +
                               ") at " + std::to_string(now_us()) + " us");
    }
  }
}

void AvrBench::send(const std::vector<std::uint8_t>& bytes) {
  for (const std::uint8_t byte : bytes) avr_raise_irq(uart_in_, byte);
}

void AvrBench::on_spdr_write(avr_t*, std::uint16_t, std::uint8_t value, void* param) {
  static_cast<AvrBench*>(param)->spdr_written(value);
}

avr_cycle_count_t AvrBench::on_spi_done(avr_t*, avr_cycle_count_t, void* param) {
  static_cast<AvrBench*>(param)->spi_done();
  return 0;
}

void AvrBench::on_tccr1b(avr_irq_t*, std::uint32_t value, void* param) {
  auto* bench = static_cast<AvrBench*>(param);
  if ((value & kTimerClockSelect) != 0 && bench->clock_start_us_ < 0) {
    bench->clock_start_us_ = bench->now_us();
  }
}

void AvrBench::on_uart(avr_irq_t*, std::uint32_t value, void* param) {
  auto* bench = static_cast<AvrBench*>(param);
  bench->uart_.push_back(UartByte{static_cast<std::uint8_t>(value), bench->now_us()});
}

void AvrBench::on_pin(avr_irq_t*, std::uint32_t value, void* param) {
  const auto* hook = static_cast<const PinHook*>(param);
  hook->bench->pin_changed(hook->index, value != 0);
}

int AvrBench::sclk_divider() const {
  static constexpr int kDivider[4] = {4, 16, 64, 128};
  int divider = kDivider[avr_->data[mcu_->spcr] & 0x03];
  if (avr_->data[mcu_->spsr] & kSpi2x) divider /= 2;
  return divider;
}

void AvrBench::spdr_written(std::uint8_t mosi) {
  const double t = now_us();
  avr_->data[mcu_->spdr] = mosi;
  avr_->data[mcu_->spsr] = static_cast<std::uint8_t>(avr_->data[mcu_->spsr] & ~kSpif);
  const std::uint8_t spcr = avr_->data[mcu_->spcr];
  if ((spcr & (kSpe | kMstr)) != (kSpe | kMstr)) {
    violations_.push_back("t=" + std::to_string(t) + " us: SPDR written with the SPI not master");
    return;
  }
  const double sclk = static_cast<double>(build_.f_cpu) / sclk_divider();
  if ((spcr & (kCpol | kCpha)) != (kCpol | kCpha) || (spcr & kDord) != 0 || sclk > kMaxSclkHz) {
    char text[128];
    std::snprintf(text, sizeof text,
                  "t=%.2f us: SPI not mode 3, MSB first at <= 2 MHz (SPCR %02x, SCLK %.0f Hz)", t,
                  spcr, sclk);
    violations_.emplace_back(text);
  }
  spi_mosi_ = mosi;
  spi_start_us_ = t;
  avr_cycle_timer_register(avr_, static_cast<avr_cycle_count_t>(8 * sclk_divider()), on_spi_done,
                           this);
}

void AvrBench::spi_done() {
  const double t = now_us();
  int selected = -1;
  int count = 0;
  for (int i = 0; i < kMaxChipSelects; ++i) {
    if (!cs_high_[i]) {
      selected = i;
      ++count;
    }
  }
  std::uint8_t miso = 0xFF;
  if (count > 1) {
    violations_.push_back("t=" + std::to_string(t) + " us: several chip selects low at once");
  } else if (count == 1 && sensor(static_cast<std::size_t>(selected)) != nullptr) {
    miso = sensors_[static_cast<std::size_t>(selected)]->exchange(spi_mosi_, spi_start_us_, t);
  }
  avr_raise_irq(spi_in_, miso);
}

void AvrBench::pin_changed(int index, bool high) {
  const double t = now_us();
  if (index < 0) {
    for (auto& s : sensors_) {
      if (s) s->reset_pin(high, t);
    }
    return;
  }
  if (cs_high_[index] == high) return;
  cs_high_[index] = high;
  SpiChip* model = sensor(static_cast<std::size_t>(index));
  if (!high) {
    if (t - last_deselect_us_ > kFrameGapUs) span_start_us_ = t;
    bursts_at_select_ = model != nullptr ? model->bursts() : 0;
  } else {
    last_deselect_us_ = t;
    const bool burst = model != nullptr && model->bursts() > bursts_at_select_;
    if (burst) {
      longest_read_us_ = std::max(longest_read_us_, t - span_start_us_);
    } else {
      // Only motion reads count towards a frame's read time.
      last_deselect_us_ = -1e9;
    }
  }
  if (model != nullptr) model->ncs_pin(high, t);
}

}  // namespace moa::firmware_sim
