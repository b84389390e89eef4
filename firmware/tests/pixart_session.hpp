// The firmware in simavr with PixArt chip models on its bus, its UART
// decoded two ways: by moa's host decoder (which skips the frame types it
// does not know, SHUTTER, as an old reader would) and by a small COBS + CRC
// splitter of the test's own, which gives the STATUS and SHUTTER payloads.
#pragma once

#include <algorithm>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <variant>
#include <vector>

#include "avr_bench.hpp"
#include "moa/sources/serial_protocol.hpp"
#include "spi_chip.hpp"

namespace moa::firmware_sim {

namespace serial = moa::io::serial;

/// Payloads of the well-formed frames in `bytes` (docs/serial-protocol.md,
/// Framing: COBS, then CRC-16/CCITT-FALSE appended little-endian).
inline std::vector<std::vector<std::uint8_t>> split_frames(const std::vector<std::uint8_t>& bytes) {
  std::vector<std::vector<std::uint8_t>> out;
  std::vector<std::uint8_t> block;
  for (const std::uint8_t byte : bytes) {
    if (byte != 0) {
      block.push_back(byte);
      continue;
    }
    std::vector<std::uint8_t> decoded;
    bool ok = !block.empty();
    for (std::size_t at = 0; ok && at < block.size();) {
      const std::size_t code = block[at++];
      if (at + code - 1 > block.size()) ok = false;
      for (std::size_t j = 1; ok && j < code; ++j) decoded.push_back(block[at++]);
      if (ok && code != 0xFF && at < block.size()) decoded.push_back(0);
    }
    block.clear();
    if (!ok || decoded.size() < 3) continue;
    std::uint16_t crc = 0xFFFF;
    for (std::size_t i = 0; i + 2 < decoded.size(); ++i) {
      crc = static_cast<std::uint16_t>(crc ^ (decoded[i] << 8));
      for (int b = 0; b < 8; ++b) {
        crc = static_cast<std::uint16_t>((crc & 0x8000) ? (crc << 1) ^ 0x1021 : crc << 1);
      }
    }
    const std::size_t n = decoded.size();
    if (decoded[n - 2] != (crc & 0xFF) || decoded[n - 1] != (crc >> 8)) continue;
    decoded.resize(n - 2);
    out.push_back(std::move(decoded));
  }
  return out;
}

/// One sensor's entry of a STATUS frame.
struct SensorState {
  std::uint8_t state;
  std::uint8_t detail;
};

class PixartSession {
 public:
  PixartSession(const FirmwareBuild& build, std::vector<std::unique_ptr<SpiChip>> chips)
      : build_(build), bench_(build, std::move(chips)) {}

  bool run_until(const std::function<bool()>& done, double timeout_us) {
    const double end = bench_.now_us() + timeout_us;
    while (!done()) {
      if (bench_.now_us() >= end) return false;
      run_for(1000.0);
    }
    return true;
  }
  void run_for(double us) {
    bench_.run_until_us(bench_.now_us() + us);
    const auto& bytes = bench_.uart();
    for (; consumed_ < bytes.size(); ++consumed_) {
      raw_.push_back(bytes[consumed_].value);
      const auto out = decoder_.push(bytes[consumed_].value);
      if (!out) continue;
      if (const auto* m = std::get_if<serial::Message>(&*out)) received_.push_back(*m);
    }
  }
  void send(const serial::Message& message) { bench_.send(serial::encode(message)); }

  std::vector<serial::Data> data() const { return of_type<serial::Data>(); }
  std::vector<serial::Hello> hellos() const { return of_type<serial::Hello>(); }
  std::vector<serial::Status> host_statuses() const { return of_type<serial::Status>(); }
  const serial::Decoder::Stats& stats() const { return decoder_.stats(); }
  AvrBench& bench() { return bench_; }
  const FirmwareBuild& build() const { return build_; }

  /// Payloads of one frame type, from the test's own splitter.
  std::vector<std::vector<std::uint8_t>> payloads(std::uint8_t type) const {
    std::vector<std::vector<std::uint8_t>> out;
    for (auto& p : split_frames(raw_)) {
      if (!p.empty() && p[0] == type) out.push_back(std::move(p));
    }
    return out;
  }
  /// The STATUS frames (type 0x04): per sensor, state and detail.
  std::vector<std::vector<SensorState>> statuses() const {
    std::vector<std::vector<SensorState>> out;
    for (const auto& p : payloads(0x04)) {
      std::vector<SensorState> s;
      for (std::size_t i = 0; 2 + 2 * i + 1 < p.size(); ++i)
        s.push_back({p[2 + 2 * i], p[3 + 2 * i]});
      if (p.size() == 2 + 2 * static_cast<std::size_t>(p[1])) out.push_back(std::move(s));
    }
    return out;
  }

  double tick_time_us(std::uint32_t timestamp) {
    return bench_.clock_start_us() + timestamp * 1e6 / (build_.f_cpu / 8.0);
  }
  /// Bursts sensor i served before the tick after the one `timestamp` names.
  std::size_t reads_through(std::size_t i, std::uint32_t timestamp) {
    const SpiChip* chip = bench_.sensor(i);
    if (chip == nullptr) return 0;
    const double t = tick_time_us(timestamp) + 1e6 / build_.frame_hz;
    const auto& times = chip->burst_times();
    return static_cast<std::size_t>(std::lower_bound(times.begin(), times.end(), t) -
                                    times.begin());
  }

  std::vector<std::string> violations() {
    std::vector<std::string> all = bench_.violations();
    for (std::size_t i = 0; i < static_cast<std::size_t>(build_.sensors); ++i) {
      if (const SpiChip* c = bench_.sensor(i)) {
        for (const std::string& v : c->violations())
          all.push_back("sensor " + std::to_string(i) + ": " + v);
      }
    }
    return all;
  }

 private:
  template <class T>
  std::vector<T> of_type() const {
    std::vector<T> out;
    for (const serial::Message& r : received_) {
      if (const auto* m = std::get_if<T>(&r)) out.push_back(*m);
    }
    return out;
  }

  FirmwareBuild build_;
  AvrBench bench_;
  serial::Decoder decoder_;
  std::vector<serial::Message> received_;
  std::vector<std::uint8_t> raw_;
  std::size_t consumed_ = 0;
};

}  // namespace moa::firmware_sim
