// The acquisition microcontroller on a serial line (docs/serial-protocol.md)
// as a FrameSource.
//
// Start: the port is set raw with termios (8N1, no flow control, the given
// baud), stale input is flushed, and HELLO_REQUEST is sent (again every
// second) until a HELLO names the sensors; DATA before the first HELLO
// cannot be read and is skipped. Every sensor the HELLO names must be in
// the robot config. Each DATA frame then gives one row per sensor, all at
// the frame's time: t = device time (unwrapped, io::serial::DataTracker) minus
// the device time of the stream's start, which is the end of the first DATA
// window minus its length K / frame rate (0 if the rate is unknown).
//
// A GYRO frame (a device with a gyro) gives one GyroSample for the DATA
// frame of its sequence number, at that frame's t: the mean z rate over the
// same window, converted to rad/s with the sensitivity the frame states.
// A GYRO frame that does not follow the DATA frame it names (that frame
// lost, dropped or never accepted) is counted and dropped.
//
// Bad bytes never stop the stream: the decoder resynchronises at the next
// delimiter, corrupt frames and frames lost (sequence gaps) are counted and
// reported through LiveHooks::warn. A device clock that steps back (a
// restart) is re-based so that times never decrease. A hang-up (unplugged
// adapter, closed pty) ends the stream with a warning.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "moa/formats/config.hpp"
#include "moa/formats/log.hpp"
#include "moa/sources/live.hpp"
#include "moa/sources/serial_protocol.hpp"

namespace moa::io {

struct SerialOptions {
  int baud = 500000;  ///< the firmware's rate (docs/firmware.md)
  /// Open read-write and set the port up with termios. Off: the path is
  /// opened read-only and used as it is (pipes, files of captured bytes);
  /// no HELLO_REQUEST can be sent then.
  bool configure_port = true;
  /// s to wait for the first HELLO and DATA before giving up.
  double start_timeout = 5.0;
};

/// The device's gyro over one DATA window is a GyroSample (sources/live.hpp)
/// at the DATA frame's row time.
class SerialReader : public FrameSource, public GyroStream {
 public:
  struct Stats {
    std::uint64_t data_frames = 0;     ///< DATA frames turned into rows
    std::uint64_t lost_frames = 0;     ///< from sequence gaps
    std::uint64_t corrupt = 0;         ///< frames dropped by the decoder
    std::uint64_t mismatched = 0;      ///< DATA whose N differs from the HELLO's
    std::uint64_t before_hello = 0;    ///< DATA skipped before the first HELLO
    std::uint64_t overflow_rows = 0;   ///< rows with the overflow flag
    std::uint64_t clock_steps = 0;     ///< device clock stepped back or ahead (re-based)
    std::uint64_t restarts = 0;        ///< a new HELLO, or the sequence restarted
    std::uint64_t duplicates = 0;      ///< DATA frames repeating the last sequence number
    std::uint64_t stale = 0;           ///< DATA frames behind the sequence, dropped
    std::uint64_t gyro_frames = 0;     ///< GYRO frames turned into samples
    std::uint64_t gyro_unmatched = 0;  ///< GYRO frames not after their DATA frame, dropped
    std::uint64_t gyro_saturated = 0;  ///< samples flagged saturated
    std::uint64_t unknown = 0;         ///< good frames of a type this host does not know, skipped
  };

  /// Opens and sets up `device`; throws io::Error "DEV: why". Does not wait
  /// for the device yet (start_time() does).
  SerialReader(const std::filesystem::path& device, const RobotConfig& config,
               const SerialOptions& options, LiveHooks hooks);
  ~SerialReader() override;

  /// 0 (rows are relative to the stream's start). Blocks until the HELLO
  /// and the first DATA; throws io::Error on timeout or if stopped first.
  double start_time() override;
  /// Blocks until a row, the stop hook, or a hang-up.
  std::optional<SensorRow> next() override;

  /// The gyro samples decoded since the last call, in time order (none
  /// from a device without a gyro). Once a first GYRO frame has come, the
  /// rows of each DATA frame are held until its GYRO frame (or the next
  /// frame, a HELLO, the end): when next() hands out a row, the sample of
  /// its window, if any, is here already.
  std::vector<GyroSample> take_gyro() override;

  /// Sends a host command (SET_K, SET_CPI, HELLO_REQUEST).
  void send(const serial::Message& message);

  /// The latest HELLO (empty names before the first).
  const serial::Hello& hello() const;
  const Stats& stats() const;
  /// s since the last good DATA frame (infinity before the first).
  double seconds_since_data() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// termios speed constant for a baud rate; nullopt if the platform has none.
std::optional<unsigned> termios_speed(int baud);

}  // namespace moa::io
