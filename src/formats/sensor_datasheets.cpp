#include "moa/formats/sensor_datasheets.hpp"

#include <fmt/core.h>

#include <array>
#include <cmath>
#include <limits>

namespace moa::io {
namespace {

constexpr double kG = 9.80665;  // m/s^2 per g
constexpr double kInf = std::numeric_limits<double>::infinity();

// Figures from each part's data sheet (its first page, "key parameters",
// unless noted); 0 where the data sheet does not give the figure.
const std::array<SensorDatasheet, 7> kSheets{{
    // Agilent HDNS-2051: 400 or 800 cpi, 14 in/s at 2300 frames/s.
    {kHdns2051, 400.0, 800.0, 400.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
     "a USB or PS/2 mouse of its day (evdev); no moa firmware driver", false, 0.0},
    // Avago ADNS-3080: 400 or 1600 cpi, 40 in/s and 15 g, up to 6469 frames/s.
    {kAdns3080, 400.0, 1600.0, 1200.0, 15.0 * kG, 0.0, 0.0, 0.0, 0.0, 0.0,
     "the moa AVR firmware, moa_firmware_atmega328p / _8mhz / _atmega8", false, 0.0},
    // PixArt PMW3360DM-T2QU (data sheet v1.50): 100 to 12000 cpi in steps of
    // 100, 250 in/s typical, 50 g, up to 12000 frames/s, resolution error 1 %
    // typical, lift-off cut at 2 mm (or 3 mm), on its LM19-LSI lens.
    {{"PMW3360", 1600.0, 250.0 * kMetresPerInch, 12000.0},
     100.0,
     12000.0,
     100.0,
     50.0 * kG,
     0.0,
     0.01,
     0.0,
     0.0,
     0.002,
     "the moa AVR firmware moa_firmware_pmw3360_atmega328p (needs PixArt's SROM image at "
     "build time), or a gaming mouse with it (evdev)",
     false,
     0.0},
    // PixArt PMW3389DM-T3QU: 50 to 16000 cpi in steps of 50, 400 in/s, 50 g,
    // on the same LM19-LSI lens.
    {{"PMW3389", 1600.0, 400.0 * kMetresPerInch, 0.0},
     50.0,
     16000.0,
     50.0,
     50.0 * kG,
     0.0,
     0.0,
     0.0,
     0.0,
     0.0,
     "the moa AVR firmware moa_firmware_pmw3389_atmega328p (needs PixArt's SROM image at "
     "build time), or a gaming mouse with it (evdev)",
     false,
     0.0},
    // PixArt PMW3901MB-TXQT: an optical flow chip focused from 80 mm to
    // infinity, rated to 7.4 rad/s of flow (speed = 7.4 rad/s x height).
    {{"PMW3901", 0.0, 0.0, 0.0},
     0.0,
     0.0,
     0.0,
     0.0,
     7.4,
     0.0,
     0.080,
     kInf,
     0.0,
     "the moa AVR firmware moa_firmware_pmw3901_atmega328p",
     false,
     0.0},
    // PixArt PAA5100JE-Q: an optical tracking chip for robots, working
    // range 15 to 35 mm over the floor with its LED.
    {{"PAA5100", 0.0, 0.0, 0.0},
     0.0,
     0.0,
     0.0,
     0.0,
     0.0,
     0.0,
     0.015,
     0.035,
     0.0,
     "the moa AVR firmware moa_firmware_paa5100_atmega328p / _atmega8",
     false,
     0.0},
    // SparkFun Optical Tracking Odometry Sensor (OTOS): a PAA5160 optical
    // chip, an LSM6DSO gyro and a microcontroller fusing them every 2.4 ms,
    // read over I2C as velocity registers of 5 / 32768 m/s a step (its
    // register map; sources/otos_registers.hpp). moa's counts of it are
    // 1 / 254000 inch = 0.1 um: the velocity's step over a 2.4 ms loop is
    // 0.37 um, so the counts' rounding stays below it.
    {{"OTOS", 254000.0, 0.0, 1.0 / 0.0024},
     0.0,
     0.0,
     0.0,
     0.0,
     0.0,
     0.0,
     0.0,
     0.0,
     0.0,
     "moa live --otos (Linux i2c-dev; docs/hardware.md)",
     true,
     2000.0 * 3.14159265358979323846 / 180.0},
}};

std::string metres(double m) { return fmt::format("{:g} mm", m * 1000.0); }

}  // namespace

std::span<const SensorDatasheet> sensor_datasheets() { return kSheets; }

const SensorDatasheet* find_sensor_datasheet(std::string_view name) {
  for (const SensorDatasheet& s : kSheets) {
    if (name == s.preset.name) return &s;
  }
  return nullptr;
}

bool cpi_settable(const SensorDatasheet& sheet, double cpi) {
  if (sheet.cpi_step <= 0.0) return false;
  if (!(cpi >= sheet.cpi_min && cpi <= sheet.cpi_max)) return false;
  const double steps = (cpi - sheet.cpi_min) / sheet.cpi_step;
  return steps == std::floor(steps);
}

std::string datasheet_lines(const SensorDatasheet& s) {
  std::string out = fmt::format("{}, from its data sheet:", s.preset.name);
  const auto line = [&out](const std::string& text) { out += "\n  " + text; };
  if (s.velocity_sensor) {
    line(
        fmt::format("resolution: none to set; it reports its velocity, which moa turns into "
                    "counts of 1/cpi inch ({:g} cpi: {:g} um a count; any cpi > 0 will do)",
                    s.preset.cpi, kMetresPerInch / s.preset.cpi * 1e6));
  } else if (s.cpi_step > 0.0) {
    line(fmt::format("resolution {:g} to {:g} cpi in steps of {:g}", s.cpi_min, s.cpi_max,
                     s.cpi_step));
  } else {
    line("resolution: none to set; its counts per inch depend on its height (measure them)");
  }
  if (s.preset.max_speed > 0.0) {
    line(fmt::format("rated speed {:g} in/s = {:g} m/s (max_speed)",
                     s.preset.max_speed / kMetresPerInch, s.preset.max_speed));
  }
  if (s.max_flow_rate > 0.0) {
    line(fmt::format("rated flow {:g} rad/s: max_speed = {:g} x height in m", s.max_flow_rate,
                     s.max_flow_rate));
  }
  if (s.max_acceleration > 0.0) {
    line(fmt::format("rated acceleration {:g} g = {:.4g} m/s^2", s.max_acceleration / kG,
                     s.max_acceleration));
  }
  if (s.preset.frame_rate > 0.0) {
    line(s.velocity_sensor ? fmt::format("its own loop: a sample every {:g} ms ({:.4g} /s)",
                                         1000.0 / s.preset.frame_rate, s.preset.frame_rate)
                           : fmt::format("frame rate up to {:g} /s", s.preset.frame_rate));
  }
  if (s.gyro_full_scale > 0.0) {
    line(
        fmt::format("its own z gyro, full scale {:.4g} rad/s: moa live feeds the first unit's "
                    "rate as the imu stream (config key imu)",
                    s.gyro_full_scale));
  }
  if (s.resolution_error > 0.0) {
    line(fmt::format("resolution error {:g} % typical (calibration finds each sensor's scale)",
                     s.resolution_error * 100.0));
  }
  if (s.height_min > 0.0) {
    line(std::isinf(s.height_max)
             ? fmt::format("working height {} and up", metres(s.height_min))
             : fmt::format("working height {} to {}", metres(s.height_min), metres(s.height_max)));
  }
  if (s.lift_off > 0.0) line(fmt::format("stops tracking when lifted {}", metres(s.lift_off)));
  line(fmt::format("read by {}", s.interface));
  return out;
}

}  // namespace moa::io
