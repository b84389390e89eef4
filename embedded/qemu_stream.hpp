// The files exchanged between the host and the Cortex-M4F program under QEMU
// (embedded/odometry_qemu.cpp): what the pipeline is fed, and what it gave.
// Raw little-endian structs, the same bytes on x86-64 and on Arm EABI (every
// double 8-aligned, padding explicit), so doubles cross exactly: no text
// formatting on the device (newlib's would allocate).
//
// Input (written by the host tool tests/tools/qemu_stream.cpp from a log):
//   StreamHeader, then header.sensors x StreamMount, then StreamRecords in
//   the order the host's io::run_odometry feeds the pipeline, the last one
//   kEnd.
// Output (written by the device): one StreamPose per OdometryStep, then one
//   StreamSummary.
#pragma once

#include <cstddef>
#include <cstdint>

namespace moa::qemu {

inline constexpr char kInputMagic[8] = {'M', 'O', 'A', 'Q', 'I', 'N', '0', '1'};
inline constexpr char kOutputMagic[8] = {'M', 'O', 'A', 'Q', 'O', 'U', 'T', '1'};

/// The pipeline's options that the host tool sets (the others are
/// OdometryOptions' defaults on both sides).
struct StreamHeader {
  char magic[8];
  std::uint32_t sensors;    ///< mounts that follow (at most kMaxSensors)
  std::uint32_t estimator;  ///< moa::EstimatorKind
  std::uint32_t use_wheels;
  std::uint32_t fuse_camera;
  std::uint32_t selected;        ///< OdometryOptions::sensors (bit i: sensor i)
  std::uint32_t self_calibrate;  ///< OdometryOptions::self_calibration.enabled
  double rate;                   ///< Hz
  double max_row_interval;       ///< s
  double max_gap;                ///< s
  double t0;                     ///< s, the first epoch's start (the log's first row)
};
static_assert(sizeof(StreamHeader) == 64);

/// moa::SensorMount, field by field.
struct StreamMount {
  double x, y;  ///< m, robot frame
  double yaw;   ///< rad
  double cpi;   ///< counts per inch
  double scale_x, scale_y;
  double max_speed;  ///< m/s, when has_max_speed
  double noise;      ///< m/s, when has_noise
  std::uint8_t mirrored, has_max_speed, has_noise, pad[5];
};
static_assert(sizeof(StreamMount) == 72);

enum class RecordKind : std::uint32_t {
  kMice = 1,    ///< a mice row: sensor, a = dx, b = dy (counts), squal, flags, faults
  kWheels = 2,  ///< a wheel row: a, b, c = vx, vy (m/s), omega (rad/s), robot frame
  kFix = 3,     ///< a camera fix: a, b = x, y (m), c = theta (rad, when has_theta),
                ///< sx, sy (m, when has_sigma)
  kEnd = 4,     ///< end of stream: t is the last mice row's time (Odometry::finish)
};

struct StreamRecord {
  RecordKind kind;
  std::int32_t sensor;
  double t;  ///< s
  double a, b, c;
  double sx, sy;
  std::uint8_t has_squal, squal, flags, has_theta, has_sigma;
  std::uint8_t faults;  ///< the simulator's fault bits (faults.csv), for the oracle
  std::uint8_t pad[2];
};
static_assert(sizeof(StreamRecord) == 64);
static_assert(offsetof(StreamRecord, t) == 8);

/// One OdometryStep: pose world_T_robot (m, m, rad, theta not wrapped) at t
/// (s), the epoch's twist (robot frame, m/s, m/s, rad/s), the sensors used.
struct StreamPose {
  double t, x, y, theta, vx, vy, omega;
  std::uint32_t used;  ///< bit i: sensor i of the config used by the estimate
  /// Instructions the pipeline executed for this step (the push calls since
  /// the previous step), from SysTick ticks under -icount: a multiple of the
  /// instructions per tick.
  std::uint32_t instructions;
};
static_assert(sizeof(StreamPose) == 64);

struct StreamSummary {
  char magic[8];
  std::uint64_t steps;
  std::uint64_t pipeline_instructions;     ///< over every push and finish call
  std::uint64_t calibration_instructions;  ///< the known loop's length
  std::uint64_t calibration_ticks;         ///< SysTick ticks it took
  std::uint64_t stack_bytes;               ///< deepest stack use seen (painted stack)
  std::uint64_t pipeline_stack_bytes;      ///< of which below the program's main frame
  std::uint64_t refused_rows;              ///< push returned an error (none expected)
};
static_assert(sizeof(StreamSummary) == 64);

}  // namespace moa::qemu
