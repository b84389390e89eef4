// Whatever bytes an OTOS unit's transfers return, through io::OtosReader:
// the start answers as a unit does (so that polls are reached), then each
// poll reads the next 13 input bytes as the unit's status, heading and
// velocity, a first byte of 0xEE failing the transfer instead (a unit that
// stops answering, and comes back). The reader must hand out rows in time
// order with whole, finite counts, and never throw nor crash.
#include <cerrno>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <string>
#include <vector>

#include "moa/formats/config.hpp"
#include "moa/sources/otos_reader.hpp"
#include "moa/sources/otos_registers.hpp"

namespace {

class FuzzUnit final : public moa::io::I2cTransport {
 public:
  FuzzUnit(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  int read(std::uint8_t reg, std::span<std::uint8_t> out) override {
    if (reg != moa::io::otos::kRegStatus) {
      // The start: the product ID, versions, scalars, config, a done IMU calibration.
      for (std::size_t i = 0; i < out.size(); ++i) {
        out[i] = reg + i == moa::io::otos::kRegProductId ? moa::io::otos::kProductId : 0;
      }
      return 0;
    }
    if (at_ < size_ && data_[at_] == 0xEE) {
      ++at_;
      return EREMOTEIO;
    }
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = at_ < size_ ? data_[at_++] : 0;
    return 0;
  }
  int write(std::uint8_t, std::span<const std::uint8_t>) override { return 0; }
  std::string where() const override { return "fuzz:0x17"; }
  bool done() const { return at_ >= size_; }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t at_ = 0;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const moa::io::RobotConfig config = moa::io::parse_config(
      "version: 1\nsensors:\n  - {name: o1, position: [0.1, 0], yaw: 0, cpi: 254000}\n",
      "robot.yaml");
  double time = 0.0;
  auto unit = std::make_unique<FuzzUnit>(data, size);
  FuzzUnit* raw = unit.get();
  std::vector<moa::io::OtosLink> links;
  links.push_back({{"o1", {"fuzz", 0x17}, 0}, std::move(unit)});
  moa::io::LiveHooks hooks;
  hooks.stop = [&] { return raw->done(); };
  moa::io::OtosReader reader(std::move(links), config, {}, hooks,
                             {[&] { return time; }, [&](double s) { time += s > 0 ? s : 1e-6; }});
  double last = 0.0;
  while (const auto row = reader.next()) {
    if (!(row->t >= last) || !row->counts.allFinite() ||
        row->counts.x() != std::round(row->counts.x()) ||
        row->counts.y() != std::round(row->counts.y())) {
      std::abort();
    }
    last = row->t;
    for (const auto& g : reader.take_gyro()) {
      if (!std::isfinite(g.gz) || g.t > last) std::abort();
    }
  }
  return 0;
}
