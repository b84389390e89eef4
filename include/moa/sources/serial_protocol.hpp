// moa serial protocol v1 (docs/serial-protocol.md): framing, CRC and the
// payloads, without any device I/O, so that the firmware tests, the host
// reader and fuzzing all use the same decoder.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <variant>
#include <vector>

namespace moa::io::serial {

inline constexpr std::uint8_t kProtocolVersion = 1;
inline constexpr std::size_t kMaxPayload = 255;
inline constexpr int kMaxSensors = 16;

enum class Type : std::uint8_t {
  kHello = 0x01,
  kData = 0x02,
  kGyro = 0x03,
  kStatus = 0x04,
  kSetK = 0x10,
  kSetCpi = 0x11,
  kHelloRequest = 0x12,
};

/// CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, no reflection, no xor-out.
std::uint16_t crc16(std::span<const std::uint8_t> bytes);

/// COBS encoding of `payload` (no trailing delimiter).
std::vector<std::uint8_t> cobs_encode(std::span<const std::uint8_t> payload);
/// COBS decoding of one block (without the delimiter); nullopt if malformed.
std::optional<std::vector<std::uint8_t>> cobs_decode(std::span<const std::uint8_t> block);

struct Hello {
  std::uint8_t version = kProtocolVersion;
  std::uint16_t k = 1;              ///< sensor frames per DATA frame
  std::uint16_t frame_rate = 0;     ///< sensor frames per second
  std::uint16_t cpi = 0;            ///< counts per inch
  std::uint32_t tick_hz = 1000000;  ///< timestamp ticks per second
  std::vector<std::string> names;   ///< one per sensor
};

struct SensorCounts {
  std::int16_t dx = 0;
  std::int16_t dy = 0;
  std::uint8_t squal = 0;
  std::uint8_t flags = 0;
};

struct Data {
  std::uint16_t sequence = 0;
  std::uint32_t timestamp = 0;  ///< ticks, wraps
  std::uint8_t n = 0;
  std::array<SensorCounts, kMaxSensors> sensors{};
};

/// The z rate of an MPU-6050 class gyro over the window of the DATA frame
/// with the same sequence number: `n` raw samples (one per sensor frame
/// read) summed. Raw LSB are counter-clockwise positive about the chip's z
/// axis; `lsb_per_dps_x10` is the sensitivity, LSB per deg/s times 10
/// (655 at +-500 deg/s).
struct Gyro {
  std::uint16_t sequence = 0;
  std::int32_t sum = 0;               ///< raw LSB summed over the n samples
  std::uint16_t n = 0;                ///< samples summed (1..65535)
  std::uint16_t lsb_per_dps_x10 = 0;  ///< > 0
  std::uint8_t flags = 0;             ///< bit 0: a sample at full scale (saturated)

  /// rad/s, the mean rate over the window (n > 0, lsb_per_dps_x10 > 0).
  double rate() const;
};
inline constexpr std::uint8_t kGyroSaturated = 0x01;

/// What each chip select of the device holds (firmware/src/sensor.h): sent
/// after every HELLO and when a sensor's state changes.
struct SensorStatus {
  std::uint8_t state = 0;   ///< 0 ok; the others: describe_sensor_state()
  std::uint8_t detail = 0;  ///< the product ID of another part, the SROM_ID read
};
struct Status {
  std::uint8_t n = 0;
  std::array<SensorStatus, kMaxSensors> sensors{};
};
inline constexpr std::uint8_t kSensorOk = 0;
/// What a STATUS state means, for a person ("another part (product ID 0x17)").
std::string describe_sensor_state(const SensorStatus& status);

struct SetK {
  std::uint16_t k = 1;
};
struct SetCpi {
  std::uint16_t cpi = 1600;
};
struct HelloRequest {};

using Message = std::variant<Hello, Data, Gyro, SetK, SetCpi, HelloRequest, Status>;

/// A whole wire frame: COBS(payload || crc16) || 0x00. Fields are written
/// as given, even out of range (so tests can make invalid frames); throws
/// io::Error only for what the format cannot hold (more than 16 DATA
/// records, a name or name list longer than 255, a payload over 255 bytes).
std::vector<std::uint8_t> encode(const Message& message);

/// Why a frame was dropped.
enum class FrameError { kCobs, kTooShort, kCrc, kUnknownType, kBadLength, kBadField };
const char* describe(FrameError error);

/// Incremental decoder: feed any bytes, get messages. Never throws on data;
/// garbage is skipped up to the next delimiter and counted. An empty block
/// (two delimiters in a row) is no frame and is not counted: a sender may
/// emit a lone 0x00 to flush the receiver. Memory stays bounded: bytes past
/// the longest valid block are dropped and the block counted as overlong
/// (and corrupt, with FrameError::kBadLength).
class Decoder {
 public:
  struct Stats {
    std::uint64_t frames = 0;    ///< good frames decoded
    std::uint64_t corrupt = 0;   ///< frames dropped (any FrameError but kUnknownType)
    std::uint64_t overlong = 0;  ///< blocks longer than any valid frame
    /// Good frames (COBS and CRC) of a type this decoder does not know: a
    /// newer device's additions, skipped without counting them corrupt.
    std::uint64_t unknown = 0;
  };

  /// Feeds one byte; returns a message when it completes a good frame, or
  /// the reason when it completes a bad one.
  std::optional<std::variant<Message, FrameError>> push(std::uint8_t byte);
  const Stats& stats() const { return stats_; }

 private:
  std::vector<std::uint8_t> block_;
  bool overlong_ = false;
  Stats stats_;
};

/// Host-side bookkeeping of DATA frames: sequence gaps, timestamp unwrap.
/// How a DATA frame follows the last one accepted (by sequence number, mod 2^16).
enum class FrameOrder {
  kNext,     ///< the first frame, or 1..2^15-1 ahead (a step d > 1: d - 1 lost)
  kRepeat,   ///< the same sequence number: a duplicated frame
  kStale,    ///< behind: an old frame delivered late
  kRestart,  ///< behind, and the frame before it was behind too, one step earlier: the
             ///< device counts again from a new start (a reset without a HELLO)
};

class DataTracker {
 public:
  /// Where `data` falls (see FrameOrder); remembers a frame found behind, so
  /// that the next one can show a restart. Does not accept it.
  FrameOrder classify(const Data& data);
  /// Returns the unwrapped time in seconds for this frame, given the tick rate
  /// (> 0). Lost frames: a sequence step of d > 1 (mod 2^16) adds d - 1.
  double accept(const Data& data, std::uint32_t tick_hz);
  std::uint64_t lost_frames() const { return lost_; }

 private:
  bool started_ = false;
  std::uint16_t last_sequence_ = 0;
  std::uint32_t last_timestamp_ = 0;
  std::int64_t wraps_ = 0;  // signed: a small step back across a wrap undoes one
  std::uint64_t lost_ = 0;
  std::optional<std::uint16_t> behind_;  // the last frame classified kStale
};

}  // namespace moa::io::serial
