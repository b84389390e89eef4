// Where live rows come from, for `moa live` and the guided calibration's
// live session: USB mice (evdev), the serial board, SparkFun OTOS units on
// I2C, or a recorded log played at its own pace. All are io::FrameSource,
// so everything after this is the same. In runs/, not sources/: it resolves a replayed log's files
// (resolve_log, runs/odometry_run.hpp).
#pragma once

#include <chrono>
#include <deque>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "moa/formats/config.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa/runs/run_loop.hpp"
#include "moa/sources/evdev.hpp"
#include "moa/sources/live.hpp"
#include "moa/sources/otos_reader.hpp"
#include "moa/sources/replay_reader.hpp"
#include "moa/sources/serial_reader.hpp"
#include "moa/sources/stream_lines.hpp"

namespace moa::io {

/// Exactly one of: `mice` not empty (evdev devices, each bound to a sensor of
/// the config), `serial` (a port), `otos` not empty (OTOS units, each bound
/// to a sensor) or `replay` (a log directory or mice.csv).
struct LiveSourceSpec {
  std::vector<EvdevDevice> mice;
  EvdevOptions evdev;
  std::vector<OtosDevice> otos;
  OtosOptions otos_options;
  std::string serial;
  SerialOptions serial_options;
  std::string replay;
  ReplayOptions replay_options;
};

struct LiveSource {
  std::unique_ptr<FrameSource> source;
  EvdevReader* evdev = nullptr;    ///< set for mice
  SerialReader* serial = nullptr;  ///< set for a serial port
  OtosReader* otos = nullptr;      ///< set for OTOS units
  ReplayReader* replay = nullptr;  ///< set for a replay
  /// The source's gyro, if it has one (the serial board's, the first OTOS
  /// unit's): LiveRunSource::add_gyro merges it in.
  GyroStream* gyro = nullptr;
  int mice = 0;       ///< evdev devices
  std::string where;  ///< for messages: "mice", the port, the log
  /// "3 mice (evdev)", the port, "a replay of DIR": what a recording came from.
  std::string origin;
  /// Status text: how many sensors are alive, frames lost.
  std::string alive(const RobotConfig& config) const;
};

/// The files the spec names (the mice's devices, the serial port, the OTOS
/// units' adapters, the replayed log's files): what no output of the run
/// may name.
std::vector<std::filesystem::path> live_source_files(const LiveSourceSpec& spec);

/// Opens the one source the spec names. Throws io::Error when none or more
/// than one is named, or the source cannot be opened; warns through `hooks`
/// when fewer mice than sensors are bound (the others read as still).
LiveSource open_live_source(const LiveSourceSpec& spec, const RobotConfig& config,
                            const std::string& config_path, const LiveHooks& hooks);

/// A live source as a run's source (runs/run_loop.hpp): first a zero row per
/// sensor at the start time, then the source's rows as they come. The zero
/// rows are no-ops for the synchroniser (its sensors all start there); they
/// start a recording's clock where the live run's did, so that the
/// recording replays to the same steps.
///
/// With the robot's streams (sources/stream_lines.hpp), their wheel rows,
/// gyro rows and fixes are merged in as a log's are (runs/odometry_run.hpp):
/// each is held until the first mice row at or after its t and handed out
/// before it, fixes first, then wheels, then gyro, so that the recording
/// replays in the same order. A line
/// without t is stamped at its arrival on the source's clock, estimated from
/// the last mice row received: t = t_row + speed (arrival - its arrival), and
/// kept after the last mice row handed out. Rows after the last mice row are
/// not handed out (a stream ends with its mice). The reader is told the
/// source's clock at each mice row (StreamLineReader::set_source_clock), so
/// that it refuses a t far ahead of it.
class LiveRunSource final : public RunSource {
 public:
  /// `where` names the source in messages; `stop`, polled before each row,
  /// ends the stream when it returns true (empty: the source decides).
  /// Waits for the source to start (FrameSource::start_time: a serial
  /// board's HELLO), so that a run's outputs are created after it.
  LiveRunSource(FrameSource& frames, int sensors, std::string where,
                std::function<bool()> stop = {});
  /// Merges the robot's streams in; `speed`: the source's seconds per
  /// second of wall time (a replay's speed; 1 for devices).
  void add_streams(StreamLineReader& streams, double speed);
  /// Merges a device's gyro samples in (the serial board's, the first OTOS
  /// unit's: GyroStream::take_gyro) as ImuRows, each before the first mice
  /// row at or after its t, after that row's fixes and wheel rows: the order
  /// a replay of imu.csv keeps. A sample that comes after the rows of its
  /// window (the first of a stream) is stamped just after them.
  void add_gyro(GyroStream& gyro);
  /// Merges a replayed log's streams in (its camera.csv, wheels.csv and
  /// imu.csv, opened by open_log_streams, runs/odometry_run.hpp) as `moa
  /// odometry` does: each row before the first mice row at or after its t,
  /// fixes first, then wheels, then gyro. `files` names them in messages.
  /// Both must outlive this.
  void add_log(LogStreams& log, const LogFiles& files);
  double start_time() override;
  const InputRow* next() override;
  std::string where() const override;
  /// Stream rows dropped: a t before its stream's previous row's (a line
  /// without t stamped after a line whose t was later).
  std::size_t dropped() const { return dropped_; }
  /// Rows of one stream that may wait for their mice row (held, not yet
  /// handed out): a stream line is at most kMaxStreamLead ahead, so this
  /// holds a minute of a 1 kHz stream.
  static constexpr std::size_t kMaxHeldRows = 65536;
  /// Stream rows dropped because kMaxHeldRows of their stream were held.
  std::size_t overflow() const { return overflow_; }
  /// The streams' rows handed out, per kind.
  struct Streamed {
    std::size_t wheels = 0, imu = 0, fixes = 0;
  };
  const Streamed& streamed() const { return streamed_; }
  /// When the last mice row handed out was received from the source (its
  /// arrival; steady clock): during a step's callback, the arrival of the
  /// row that completed the step (`moa bench --live`).
  std::chrono::steady_clock::time_point last_arrival() const { return arrival_last_; }

 private:
  void take_streams();
  void take_gyro();
  FrameSource& frames_;
  int sensors_;
  std::string where_;
  std::function<bool()> stop_;
  double t0_;        ///< s, the source's start time
  int started_ = 0;  ///< zero rows handed out
  InputRow row_;
  bool from_streams_ = false;  ///< row_ came from the streams
  // The streams' merge.
  StreamLineReader* streams_ = nullptr;
  double speed_ = 1.0;
  std::optional<SensorRow> pending_;  ///< the next mice row, not yet handed out
  bool ended_ = false;
  double t_last_ = 0.0;                                 ///< s, the last mice row handed out
  double t_ref_ = 0.0;                                  ///< s, the last mice row received ...
  std::chrono::steady_clock::time_point arrival_ref_;   ///< ... and when
  std::chrono::steady_clock::time_point arrival_last_;  ///< of the last mice row handed out
  std::deque<WheelRow> wheels_;
  std::deque<ImuRow> gyro_;
  std::deque<CameraFix> fixes_;
  std::vector<StreamRow> arrived_;
  /// A stream's last row: its own t (given, or stamped at arrival) and the
  /// t it was fed at (raised when it arrived late), s.
  struct StreamOrder {
    double own = -std::numeric_limits<double>::infinity();
    double fed = -std::numeric_limits<double>::infinity();
  };
  StreamOrder wheel_order_, gyro_order_, fix_order_;
  std::size_t dropped_ = 0;
  std::size_t overflow_ = 0;
  Streamed streamed_;
  GyroStream* gyro_serial_ = nullptr;  ///< the device's gyro (add_gyro)
  std::deque<ImuRow> serial_gyro_;     ///< its samples, not yet handed out
  // A replayed log's streams (add_log), and each one's next row, not yet handed out.
  LogStreams* log_ = nullptr;
  const LogFiles* log_files_ = nullptr;
  std::optional<CameraRow> log_fix_;
  std::optional<WheelRow> log_wheel_;
  std::optional<ImuRow> log_gyro_;
  /// The file row_ came from, when one of the log's streams.
  const std::optional<std::filesystem::path>* from_log_ = nullptr;
};

}  // namespace moa::io
