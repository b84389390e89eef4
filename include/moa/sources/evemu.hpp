// evemu recordings (evemu-record, Linux): mouse motion from files.
//
// Two layouts are read:
//   - new style: one file, a "# EVEMU 1.x" header, the device description
//     (lines "N:", "I:", "P:", "B:", "A:", ...) and the events;
//   - old style: the description in NAME.desc, the events alone in
//     NAME.events. Either path, or NAME alone, may be given; the other file
//     is looked up beside it (the .desc is optional).
// Event lines are "E: SEC.USEC TYPE CODE VALUE [# comment]", TYPE and CODE
// hexadecimal, VALUE base 10 whatever its leading zeros ("-013" is -13).
//
// A frame is every event up to EV_SYN/SYN_REPORT (type 0, code 0), never a
// run of equal timestamps (old recordings stamp the SYN_REPORT a few us after
// the motion). A frame with REL_X (type 2, code 0) or REL_Y (type 2, code 1)
// motion becomes one row: dx = sum of REL_X, dy = sum of REL_Y, raw evdev
// counts (+REL_Y is "down the screen"; the mounting in the robot config maps
// them), t = the SYN_REPORT's time. Every count is kept: a frame cut off by
// the end of the file is still a row (at its last event's time), and after
// EV_SYN/SYN_DROPPED the counts that follow are real motion and are kept too
// (relative axes have no state to resynchronise; the drop is counted).
//
// Malformed input throws io::Error "FILE:LINE: what": an unknown line, a
// missing field, a time that is not SEC.FRACTION, a type or code that is not
// 1-4 hex digits, a value that is not a base-10 32-bit integer, text after
// the value, a time earlier than the previous event's, or "FILE: no events".
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "moa/formats/log.hpp"

namespace moa::io {

struct EvemuInput {
  std::string name;            ///< sensor name the rows carry
  std::filesystem::path file;  ///< .events, .desc, or a new-style recording
};

/// What one recording held, for checks and reports.
struct EvemuStats {
  std::string device;             ///< device name from "N:", empty if none
  std::filesystem::path events;   ///< the file the events were read from
  std::uint64_t events_read = 0;  ///< event lines
  std::uint64_t frames = 0;       ///< rows: frames with REL_X/REL_Y motion
  std::int64_t sum_dx = 0;        ///< sum of all REL_X values
  std::int64_t sum_dy = 0;        ///< sum of all REL_Y values
  std::uint64_t dropped = 0;      ///< EV_SYN/SYN_DROPPED events
  bool unterminated = false;      ///< the file ended inside a frame with motion
};

/// Several recordings merged in time, as one FrameSource: row.sensor is the
/// index of the input, t is seconds after the earliest event over all files
/// (start_time() is 0). Streams: memory does not grow with the files.
class EvemuReader : public FrameSource {
 public:
  /// Opens every file and reads up to its first event; throws io::Error.
  explicit EvemuReader(const std::vector<EvemuInput>& inputs);
  ~EvemuReader() override;
  double start_time() override;
  std::optional<SensorRow> next() override;

  /// Per input, updated as rows are read (complete once next() is nullopt).
  const EvemuStats& stats(int input) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace moa::io
