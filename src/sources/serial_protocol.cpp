#include "moa/sources/serial_protocol.hpp"

#include <cassert>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>
#include <type_traits>

#include "moa/formats/error.hpp"

namespace moa::io::serial {
namespace {

// The longest COBS block a valid frame can produce: payload and CRC, plus
// one code byte per started run of 254 (counted generously).
constexpr std::size_t kMaxFrameBytes = kMaxPayload + 2;
constexpr std::size_t kMaxBlock = kMaxFrameBytes + kMaxFrameBytes / 254 + 1;

constexpr std::size_t kHelloFixed = 13;  // bytes before the names
constexpr std::size_t kDataFixed = 8;    // bytes before the sensor records
constexpr std::size_t kDataRecord = 6;
constexpr std::size_t kGyroLength = 12;
constexpr std::size_t kMaxNameLength = 15;
constexpr std::uint16_t kMaxK = 1000;

// ------------------------------------------------------------ little endian

void put_u16(std::vector<std::uint8_t>& out, std::uint16_t value) {
  out.push_back(static_cast<std::uint8_t>(value & 0xFFu));
  out.push_back(static_cast<std::uint8_t>(value >> 8));
}

void put_u32(std::vector<std::uint8_t>& out, std::uint32_t value) {
  for (int shift = 0; shift < 32; shift += 8) {
    out.push_back(static_cast<std::uint8_t>((value >> shift) & 0xFFu));
  }
}

std::uint16_t get_u16(std::span<const std::uint8_t> bytes, std::size_t at) {
  return static_cast<std::uint16_t>(bytes[at] | (bytes[at + 1] << 8));
}

std::uint32_t get_u32(std::span<const std::uint8_t> bytes, std::size_t at) {
  std::uint32_t value = 0;
  for (std::size_t i = 0; i < 4; ++i) value |= std::uint32_t{bytes[at + i]} << (8 * i);
  return value;
}

std::int32_t get_i32(std::span<const std::uint8_t> bytes, std::size_t at) {
  const std::int64_t raw = get_u32(bytes, at);
  return static_cast<std::int32_t>(raw >= 0x80000000LL ? raw - 0x100000000LL : raw);
}

// Two's complement from the raw 16 bits, without implementation-defined casts.
std::int16_t get_i16(std::span<const std::uint8_t> bytes, std::size_t at) {
  const int raw = get_u16(bytes, at);
  return static_cast<std::int16_t>(raw >= 0x8000 ? raw - 0x10000 : raw);
}

std::uint16_t raw_i16(std::int16_t value) { return static_cast<std::uint16_t>(value); }

// ------------------------------------------------------------------ payload

// Sensor names end up as mice.csv fields and config keys: printable ASCII
// without spaces, and without the comma that would split a CSV field.
bool valid_name_byte(std::uint8_t byte) { return byte > 0x20 && byte < 0x7F && byte != ','; }

std::vector<std::uint8_t> payload_of(const Message& message) {
  std::vector<std::uint8_t> out;
  std::visit(
      [&out](const auto& m) {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, Hello>) {
          if (m.names.size() > 255) throw Error("serial: HELLO with more than 255 names");
          out.push_back(static_cast<std::uint8_t>(Type::kHello));
          out.push_back(m.version);
          out.push_back(static_cast<std::uint8_t>(m.names.size()));
          put_u16(out, m.k);
          put_u16(out, m.frame_rate);
          put_u16(out, m.cpi);
          put_u32(out, m.tick_hz);
          for (const auto& name : m.names) {
            if (name.size() > 255) throw Error("serial: HELLO sensor name longer than 255 bytes");
            out.push_back(static_cast<std::uint8_t>(name.size()));
            out.insert(out.end(), name.begin(), name.end());
          }
        } else if constexpr (std::is_same_v<T, Data>) {
          if (m.n > kMaxSensors) throw Error("serial: DATA with more than 16 sensors");
          out.push_back(static_cast<std::uint8_t>(Type::kData));
          put_u16(out, m.sequence);
          put_u32(out, m.timestamp);
          out.push_back(m.n);
          for (std::size_t i = 0; i < m.n; ++i) {
            put_u16(out, raw_i16(m.sensors[i].dx));
            put_u16(out, raw_i16(m.sensors[i].dy));
            out.push_back(m.sensors[i].squal);
            out.push_back(m.sensors[i].flags);
          }
        } else if constexpr (std::is_same_v<T, Gyro>) {
          out.push_back(static_cast<std::uint8_t>(Type::kGyro));
          put_u16(out, m.sequence);
          put_u32(out, static_cast<std::uint32_t>(m.sum));
          put_u16(out, m.n);
          put_u16(out, m.lsb_per_dps_x10);
          out.push_back(m.flags);
        } else if constexpr (std::is_same_v<T, Status>) {
          if (m.n > kMaxSensors) throw Error("serial: STATUS with more than 16 sensors");
          out.push_back(static_cast<std::uint8_t>(Type::kStatus));
          out.push_back(m.n);
          for (std::size_t i = 0; i < m.n; ++i) {
            out.push_back(m.sensors[i].state);
            out.push_back(m.sensors[i].detail);
          }
        } else if constexpr (std::is_same_v<T, SetK>) {
          out.push_back(static_cast<std::uint8_t>(Type::kSetK));
          put_u16(out, m.k);
        } else if constexpr (std::is_same_v<T, SetCpi>) {
          out.push_back(static_cast<std::uint8_t>(Type::kSetCpi));
          put_u16(out, m.cpi);
        } else {
          static_assert(std::is_same_v<T, HelloRequest>);
          out.push_back(static_cast<std::uint8_t>(Type::kHelloRequest));
        }
      },
      message);
  if (out.size() > kMaxPayload) throw Error("serial: payload longer than 255 bytes");
  return out;
}

std::variant<Message, FrameError> parse_hello(std::span<const std::uint8_t> p) {
  if (p.size() < kHelloFixed) return FrameError::kBadLength;
  Hello hello;
  hello.version = p[1];
  const std::size_t n = p[2];
  hello.k = get_u16(p, 3);
  hello.frame_rate = get_u16(p, 5);
  hello.cpi = get_u16(p, 7);
  hello.tick_hz = get_u32(p, 9);
  // Another version may lay out the rest differently: nothing after the
  // version byte can be trusted then.
  if (hello.version != kProtocolVersion) return FrameError::kBadField;
  if (n < 1 || n > static_cast<std::size_t>(kMaxSensors)) return FrameError::kBadField;
  if (hello.k < 1 || hello.k > kMaxK || hello.tick_hz == 0) return FrameError::kBadField;
  std::size_t at = kHelloFixed;
  for (std::size_t i = 0; i < n; ++i) {
    if (at >= p.size()) return FrameError::kBadLength;
    const std::size_t length = p[at++];
    if (length < 1 || length > kMaxNameLength) return FrameError::kBadField;
    if (at + length > p.size()) return FrameError::kBadLength;
    std::string name;
    for (std::size_t j = 0; j < length; ++j) {
      if (!valid_name_byte(p[at + j])) return FrameError::kBadField;
      name.push_back(static_cast<char>(p[at + j]));
    }
    at += length;
    hello.names.push_back(std::move(name));
  }
  if (at != p.size()) return FrameError::kBadLength;
  return Message{std::move(hello)};
}

std::variant<Message, FrameError> parse_data(std::span<const std::uint8_t> p) {
  if (p.size() < kDataFixed) return FrameError::kBadLength;
  Data data;
  data.sequence = get_u16(p, 1);
  data.timestamp = get_u32(p, 3);
  data.n = p[7];
  if (data.n < 1 || data.n > kMaxSensors) return FrameError::kBadField;
  if (p.size() != kDataFixed + kDataRecord * data.n) return FrameError::kBadLength;
  for (std::size_t i = 0; i < data.n; ++i) {
    const std::size_t at = kDataFixed + kDataRecord * i;
    SensorCounts& s = data.sensors[i];
    s.dx = get_i16(p, at);
    s.dy = get_i16(p, at + 2);
    s.squal = p[at + 4];
    s.flags = p[at + 5];
  }
  return Message{data};
}

std::variant<Message, FrameError> parse_gyro(std::span<const std::uint8_t> p) {
  if (p.size() != kGyroLength) return FrameError::kBadLength;
  Gyro gyro;
  gyro.sequence = get_u16(p, 1);
  gyro.sum = get_i32(p, 3);
  gyro.n = get_u16(p, 7);
  gyro.lsb_per_dps_x10 = get_u16(p, 9);
  gyro.flags = p[11];
  if (gyro.n == 0 || gyro.lsb_per_dps_x10 == 0) return FrameError::kBadField;
  return Message{gyro};
}

std::variant<Message, FrameError> parse_status(std::span<const std::uint8_t> p) {
  if (p.size() < 2) return FrameError::kBadLength;
  Status status;
  status.n = p[1];
  if (status.n < 1 || status.n > kMaxSensors) return FrameError::kBadField;
  if (p.size() != 2 + 2 * static_cast<std::size_t>(status.n)) return FrameError::kBadLength;
  for (std::size_t i = 0; i < status.n; ++i) {
    status.sensors[i].state = p[2 + 2 * i];
    status.sensors[i].detail = p[3 + 2 * i];
  }
  return Message{status};
}

std::variant<Message, FrameError> parse_payload(std::span<const std::uint8_t> p) {
  switch (p[0]) {
    case static_cast<std::uint8_t>(Type::kHello):
      return parse_hello(p);
    case static_cast<std::uint8_t>(Type::kData):
      return parse_data(p);
    case static_cast<std::uint8_t>(Type::kGyro):
      return parse_gyro(p);
    case static_cast<std::uint8_t>(Type::kStatus):
      return parse_status(p);
    case static_cast<std::uint8_t>(Type::kSetK): {
      if (p.size() != 3) return FrameError::kBadLength;
      const SetK set{get_u16(p, 1)};
      if (set.k < 1 || set.k > kMaxK) return FrameError::kBadField;
      return Message{set};
    }
    case static_cast<std::uint8_t>(Type::kSetCpi): {
      if (p.size() != 3) return FrameError::kBadLength;
      const SetCpi set{get_u16(p, 1)};
      if (set.cpi == 0) return FrameError::kBadField;
      return Message{set};
    }
    case static_cast<std::uint8_t>(Type::kHelloRequest):
      if (p.size() != 1) return FrameError::kBadLength;
      return Message{HelloRequest{}};
    default:
      return FrameError::kUnknownType;
  }
}

}  // namespace

std::string describe_sensor_state(const SensorStatus& status) {
  char id[8];
  std::snprintf(id, sizeof id, "0x%02x", status.detail);
  switch (status.state) {
    case 0:
      return "ok";
    case 1:
      return "no answer (product ID read 0x00 or 0xff: check its wiring, power and logic level)";
    case 2:
      return std::string("another part (product ID ") + id + "), left alone";
    case 3:
      return "no SROM: the firmware was built without PixArt's image (docs/firmware.md)";
    case 4:
      return std::string("SROM refused (SROM_ID ") + id +
             "): the wrong image for this chip, or the CRC test failed";
    case 5:
      return "stopped answering; not read until the device restarts";
    case 6:
      return "its resolution did not read back; not read until the device restarts";
    default:
      return "state " + std::to_string(status.state);
  }
}

double Gyro::rate() const {
  // mean LSB / (LSB per deg/s) = deg/s; times pi/180 = rad/s.
  const double dps = static_cast<double>(sum) / n / (lsb_per_dps_x10 / 10.0);
  return dps * std::numbers::pi / 180.0;
}

// --------------------------------------------------------------------- CRC

std::uint16_t crc16(std::span<const std::uint8_t> bytes) {
  std::uint16_t crc = 0xFFFF;
  for (const std::uint8_t byte : bytes) {
    crc = static_cast<std::uint16_t>(crc ^ (byte << 8));
    for (int bit = 0; bit < 8; ++bit) {
      crc = (crc & 0x8000u) ? static_cast<std::uint16_t>((crc << 1) ^ 0x1021u)
                            : static_cast<std::uint16_t>(crc << 1);
    }
  }
  return crc;
}

// -------------------------------------------------------------------- COBS

std::vector<std::uint8_t> cobs_encode(std::span<const std::uint8_t> payload) {
  std::vector<std::uint8_t> out;
  out.reserve(payload.size() + payload.size() / 254 + 2);
  std::size_t code_at = 0;
  out.push_back(0);  // code of the first run, filled in when the run ends
  std::uint8_t code = 1;
  for (std::size_t i = 0; i < payload.size(); ++i) {
    const std::uint8_t byte = payload[i];
    if (byte == 0) {
      out[code_at] = code;
      code_at = out.size();
      out.push_back(0);
      code = 1;
      continue;
    }
    out.push_back(byte);
    // A full run of 254 non-zero bytes carries no implied zero; a new run
    // starts only if more bytes follow (the shortest encoding).
    if (++code == 0xFF && i + 1 < payload.size()) {
      out[code_at] = code;
      code_at = out.size();
      out.push_back(0);
      code = 1;
    }
  }
  out[code_at] = code;
  return out;
}

std::optional<std::vector<std::uint8_t>> cobs_decode(std::span<const std::uint8_t> block) {
  std::vector<std::uint8_t> out;
  out.reserve(block.size());
  std::size_t at = 0;
  while (at < block.size()) {
    const std::uint8_t code = block[at++];
    if (code == 0) return std::nullopt;
    const std::size_t run = code - 1u;
    if (at + run > block.size()) return std::nullopt;
    for (std::size_t i = 0; i < run; ++i) {
      if (block[at + i] == 0) return std::nullopt;
      out.push_back(block[at + i]);
    }
    at += run;
    // Every run but a full one (0xFF) and the last ends in a zero.
    if (code != 0xFF && at < block.size()) out.push_back(0);
  }
  return out;
}

// ------------------------------------------------------------------ frames

std::vector<std::uint8_t> encode(const Message& message) {
  std::vector<std::uint8_t> frame = payload_of(message);
  const std::uint16_t crc = crc16(frame);
  put_u16(frame, crc);
  std::vector<std::uint8_t> wire = cobs_encode(frame);
  wire.push_back(0);
  return wire;
}

const char* describe(FrameError error) {
  switch (error) {
    case FrameError::kCobs:
      return "malformed COBS block";
    case FrameError::kTooShort:
      return "frame shorter than a type byte and a CRC";
    case FrameError::kCrc:
      return "CRC mismatch";
    case FrameError::kUnknownType:
      return "unknown frame type";
    case FrameError::kBadLength:
      return "frame length does not match its type, or longer than 255 payload bytes";
    case FrameError::kBadField:
      return "field out of range (version, sensor count, K, tick rate, sensor name, gyro samples "
             "or sensitivity)";
  }
  return "invalid frame error";
}

std::optional<std::variant<Message, FrameError>> Decoder::push(std::uint8_t byte) {
  if (byte != 0) {
    // Past the longest valid block the bytes are not kept: memory stays
    // bounded whatever the line carries.
    if (block_.size() >= kMaxBlock) {
      overlong_ = true;
    } else {
      block_.push_back(byte);
    }
    return std::nullopt;
  }

  // A delimiter. Back-to-back delimiters (an empty block) are not a frame:
  // senders may emit a lone 0x00 to flush the receiver.
  if (block_.empty() && !overlong_) return std::nullopt;
  const auto fail = [this](FrameError error) -> std::optional<std::variant<Message, FrameError>> {
    block_.clear();
    ++stats_.corrupt;
    return std::variant<Message, FrameError>{error};
  };
  if (overlong_) {
    overlong_ = false;
    ++stats_.overlong;
    return fail(FrameError::kBadLength);
  }
  const auto decoded = cobs_decode(block_);
  if (!decoded) return fail(FrameError::kCobs);
  const std::vector<std::uint8_t>& frame = *decoded;
  if (frame.size() < 3) return fail(FrameError::kTooShort);
  if (frame.size() > kMaxFrameBytes) return fail(FrameError::kBadLength);
  const std::span<const std::uint8_t> payload(frame.data(), frame.size() - 2);
  const std::uint16_t crc = get_u16(frame, frame.size() - 2);
  if (crc16(payload) != crc) return fail(FrameError::kCrc);
  auto parsed = parse_payload(payload);
  if (const auto* error = std::get_if<FrameError>(&parsed)) {
    // A good frame of a type added after this decoder: skipped, not corrupt.
    if (*error == FrameError::kUnknownType) {
      block_.clear();
      ++stats_.unknown;
      return std::variant<Message, FrameError>{*error};
    }
    return fail(*error);
  }
  block_.clear();
  ++stats_.frames;
  return std::variant<Message, FrameError>{std::move(std::get<Message>(parsed))};
}

// ------------------------------------------------------------- DataTracker

FrameOrder DataTracker::classify(const Data& data) {
  if (!started_) return FrameOrder::kNext;
  const auto step = static_cast<std::uint16_t>(data.sequence - last_sequence_);
  if (step == 0) return FrameOrder::kRepeat;
  if (step < 0x8000u) return FrameOrder::kNext;
  const bool follows = behind_ && static_cast<std::uint16_t>(*behind_ + 1u) == data.sequence;
  behind_ = data.sequence;
  return follows ? FrameOrder::kRestart : FrameOrder::kStale;
}

double DataTracker::accept(const Data& data, std::uint32_t tick_hz) {
  assert(tick_hz > 0);
  behind_.reset();
  if (!started_) {
    started_ = true;
  } else {
    // Sequence numbers count modulo 2^16: a gap of d means d - 1 frames
    // never arrived. A repeated number (d = 0) loses nothing.
    const std::uint16_t step = static_cast<std::uint16_t>(data.sequence - last_sequence_);
    if (step > 1) lost_ += step - 1u;
    // Timestamps wrap modulo 2^32: the shorter way round is the true step,
    // so a step back by more than half the range is a wrap forwards, and a
    // step forwards by more than half the range is a small step back across
    // a wrap.
    const std::uint32_t half = std::uint32_t{1} << 31;
    if (data.timestamp < last_timestamp_ && last_timestamp_ - data.timestamp > half) ++wraps_;
    if (data.timestamp > last_timestamp_ && data.timestamp - last_timestamp_ > half) --wraps_;
  }
  last_sequence_ = data.sequence;
  last_timestamp_ = data.timestamp;
  const double ticks =
      static_cast<double>(wraps_) * 4294967296.0 + static_cast<double>(data.timestamp);
  return ticks / static_cast<double>(tick_hz);
}

}  // namespace moa::io::serial
