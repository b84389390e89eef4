// The library's odometry pipeline (moa::Odometry) on an emulated Cortex-M4F:
// QEMU's mps2-an386 machine, files and console through semihosting. It reads
// a log the host packed (embedded/qemu_stream.hpp: the sensor mounts, the
// options, mice rows, wheel rows and camera fixes in the order the host's
// io::run_odometry feeds them), runs it through the same Odometry type as
// `moa odometry`, and writes every step's pose and twist back, so that the
// host can compare them with its own odometry.csv (embedded/run_qemu.cmake).
//
//   qemu-system-arm -machine mps2-an386 -nographic -monitor none
//       -semihosting-config enable=on,target=native,arg=odometry_qemu,arg=IN,arg=OUT
//       -icount shift=0 -kernel odometry_qemu.elf
//
// With -icount shift=0 QEMU advances virtual time by 1 ns per instruction,
// and the SysTick, clocked from the 25 MHz system clock, counts virtual
// time: one tick per 40 instructions. The program checks that ratio on a
// loop of known length, then reports the instructions the pipeline took per
// step (QEMU counts instructions, not cycles: a real M4F takes more cycles
// than instructions, for loads, branches and divisions).
//
// No heap, as consensus_m4f: the pipeline lives in static storage.
#include <array>
#include <cstdint>
#include <cstring>
#include <optional>
#include <span>

#include "moa/core/array.hpp"
#include "moa/core/odometry.hpp"
#include "moa/core/sensor.hpp"
#include "qemu_stream.hpp"
#include "semihosting.hpp"

extern "C" {
// From mps2_an386.ld: the main stack, [__stack_bottom, __stack_top).
extern std::uint32_t __stack_bottom[], __stack_top[];
[[noreturn]] void moa_m4f_main();
void default_handler();
}

namespace {

namespace sh = moa::semihosting;
namespace q = moa::qemu;

// ---- console ----------------------------------------------------------------

void print_unsigned(std::uint64_t value) {
  char text[24];
  char* p = text + sizeof(text);
  *--p = '\0';
  do {
    *--p = static_cast<char>('0' + value % 10);
    value /= 10;
  } while (value != 0);
  sh::print(p);
}

[[noreturn]] void fail(const char* what) {
  sh::print("odometry_qemu: ");
  sh::print(what);
  sh::print("\n");
  sh::exit(false);
}

// ---- SysTick: virtual time under -icount -----------------------------------

volatile std::uint32_t& reg(std::uint32_t address) {
  return *reinterpret_cast<volatile std::uint32_t*>(address);
}
constexpr std::uint32_t kSystCsr = 0xE000E010u;    // control and status
constexpr std::uint32_t kSystRvr = 0xE000E014u;    // reload value
constexpr std::uint32_t kSystCvr = 0xE000E018u;    // current value
constexpr std::uint32_t kSysTickMask = 0xFFFFFFu;  // a 24-bit down-counter

void start_systick() {
  reg(kSystRvr) = kSysTickMask;
  reg(kSystCvr) = 0;      // any write clears it; it reloads on the next tick
  reg(kSystCsr) = 0b101;  // enable, processor clock, no interrupt
}
std::uint32_t systick() { return reg(kSystCvr); }
/// Ticks from `start` to `end` of the down-counter (less than one wrap apart:
/// 2^24 ticks, 671 million instructions).
std::uint32_t ticks_between(std::uint32_t start, std::uint32_t end) {
  return (start - end) & kSysTickMask;
}

/// Runs 2 * n instructions (subs, bne) and returns the ticks they took.
std::uint32_t calibration_ticks(std::uint32_t n) {
  const std::uint32_t start = systick();
  asm volatile(
      "1: subs %0, %0, #1\n\t"
      "bne 1b"
      : "+r"(n)
      :
      : "cc");
  return ticks_between(start, systick());
}

// ---- stack painting ----------------------------------------------------------

constexpr std::uint32_t kPaint = 0x5AC4C0DEu;

std::uint32_t* stack_pointer() {
  std::uint32_t* sp = nullptr;
  asm volatile("mov %0, sp" : "=r"(sp));
  return sp;
}

/// Fills the free stack below the caller's frame with kPaint.
void paint_stack() {
  for (std::uint32_t *p = __stack_bottom, *end = stack_pointer() - 64; p < end; ++p) *p = kPaint;
}

/// The lowest stack address written since paint_stack().
const std::uint32_t* stack_low_water() {
  const std::uint32_t* p = __stack_bottom;
  while (p < __stack_top && *p == kPaint) ++p;
  return p;
}

// ---- input and output files -------------------------------------------------

class RecordReader {
 public:
  explicit RecordReader(std::int32_t handle) : handle_(handle) {}
  /// The next record, or false at the end of the file (a partial record fails).
  bool next(q::StreamRecord& record) {
    if (index_ == count_) {
      const std::size_t bytes = sh::read(handle_, buffer_.data(), sizeof(buffer_));
      if (bytes % sizeof(q::StreamRecord) != 0) fail("input: a partial record");
      count_ = bytes / sizeof(q::StreamRecord);
      index_ = 0;
      if (count_ == 0) return false;
    }
    record = buffer_[index_++];
    return true;
  }

 private:
  std::int32_t handle_;
  std::array<q::StreamRecord, 64> buffer_{};
  std::size_t index_ = 0, count_ = 0;
};

class PoseWriter {
 public:
  explicit PoseWriter(std::int32_t handle) : handle_(handle) {}
  q::StreamPose& add() {
    if (count_ == buffer_.size()) flush();
    return buffer_[count_++];
  }
  /// The pose added `back` calls ago, if still buffered.
  q::StreamPose* recent(std::size_t back) {
    return back < count_ ? &buffer_[count_ - 1 - back] : nullptr;
  }
  void flush() {
    if (count_ != 0 && !sh::write(handle_, buffer_.data(), count_ * sizeof(q::StreamPose))) {
      fail("output: write failed");
    }
    count_ = 0;
  }

 private:
  std::int32_t handle_;
  std::array<q::StreamPose, 1024> buffer_{};
  std::size_t count_ = 0;
};

// The pipeline and the file buffers, in .bss.
std::optional<moa::Odometry> g_odometry;
std::optional<RecordReader> g_reader;
std::optional<PoseWriter> g_writer;

/// argv[1] and argv[2] of the semihosting command line, else the defaults.
struct Files {
  char input[128] = "moa_in.bin";
  char output[128] = "moa_out.bin";
};
Files files_from_command_line() {
  Files files;
  char line[512];
  if (!sh::command_line(line, sizeof(line))) return files;
  char* words[3] = {};
  int n = 0;
  for (char* p = line; *p != '\0' && n < 3;) {
    while (*p == ' ') *p++ = '\0';
    if (*p == '\0') break;
    words[n++] = p;
    while (*p != '\0' && *p != ' ') ++p;
  }
  const auto copy = [](char* to, const char* from) {
    std::size_t i = 0;
    for (; from[i] != '\0' && i + 1 < sizeof(Files::input); ++i) to[i] = from[i];
    to[i] = '\0';
  };
  if (n > 1) copy(files.input, words[1]);
  if (n > 2) copy(files.output, words[2]);
  return files;
}

moa::SensorMount mount_from(const q::StreamMount& m) {
  moa::SensorMount mount;
  mount.position = moa::Vec2(static_cast<moa::real>(m.x), static_cast<moa::real>(m.y));
  mount.yaw = static_cast<moa::real>(m.yaw);
  mount.cpi = static_cast<moa::real>(m.cpi);
  mount.scale = moa::Vec2(static_cast<moa::real>(m.scale_x), static_cast<moa::real>(m.scale_y));
  mount.mirrored = m.mirrored != 0;
  if (m.has_max_speed != 0) mount.max_speed = static_cast<moa::real>(m.max_speed);
  if (m.has_noise != 0) mount.noise = static_cast<moa::real>(m.noise);
  return mount;
}

}  // namespace

// A fault (a bad access, the FPU off) ends the emulation with a failure
// instead of spinning until the test's timeout (startup.cpp's is weak).
extern "C" void default_handler() { fail("fault or unexpected exception"); }

extern "C" [[noreturn]] void moa_m4f_main() {
  // This function's frame is set up on entry and fixed from here on: what
  // the calls below it use is the pipeline's stack (plus the file buffers'
  // few words).
  const std::uint32_t* const main_sp = stack_pointer();
  paint_stack();
  start_systick();

  // 2 instructions per iteration: 2 000 000 instructions, 50 000 ticks when
  // one instruction is 1 ns and the SysTick runs at 25 MHz.
  constexpr std::uint32_t kLoop = 1000000;
  const std::uint32_t calibration = calibration_ticks(kLoop);
  if (calibration == 0) fail("SysTick does not count: run QEMU with -icount shift=0");
  // Instructions per tick, rounded: 40 under -icount shift=0 on mps2-an386.
  const std::uint32_t per_tick = (2 * kLoop + calibration / 2) / calibration;

  const Files files = files_from_command_line();
  const std::int32_t in = sh::open(files.input, sh::kReadBinary);
  if (in < 0) fail("cannot open the input file");
  const std::int32_t out = sh::open(files.output, sh::kWriteBinary);
  if (out < 0) fail("cannot open the output file");

  q::StreamHeader header{};
  if (sh::read(in, &header, sizeof(header)) != sizeof(header) ||
      std::memcmp(header.magic, q::kInputMagic, sizeof(header.magic)) != 0) {
    fail("input: not a packed log (tests/tools/qemu_stream pack)");
  }
  if (header.sensors == 0 || header.sensors > static_cast<std::uint32_t>(moa::kMaxSensors)) {
    fail("input: sensor count out of range");
  }
  std::array<moa::SensorMount, moa::kMaxSensors> mounts{};
  for (std::uint32_t i = 0; i < header.sensors; ++i) {
    q::StreamMount m{};
    if (sh::read(in, &m, sizeof(m)) != sizeof(m)) fail("input: truncated mounts");
    mounts[i] = mount_from(m);
  }
  const moa::SensorArray array(std::span<const moa::SensorMount>(mounts.data(), header.sensors));

  moa::OdometryOptions options;
  options.estimator = static_cast<moa::EstimatorKind>(header.estimator);
  options.use_wheels = header.use_wheels != 0;
  options.fuse_camera = header.fuse_camera != 0;
  options.sensors = header.selected;
  options.self_calibration.enabled = header.self_calibrate != 0;
  options.rate = header.rate;
  options.max_row_interval = header.max_row_interval;
  options.max_gap = header.max_gap;
  if (const auto e = options.validate()) fail(e->message());
  g_odometry.emplace(array, header.t0, options);
  if (g_odometry->geometry_error()) fail(moa::describe(*g_odometry->geometry_error()));

  g_reader.emplace(in);
  g_writer.emplace(out);
  std::size_t emitted = 0;  // steps of the current call
  const auto sink = [&emitted](const moa::OdometryStep& step) {
    q::StreamPose& p = g_writer->add();
    p.t = step.t();
    p.x = step.pose.t.x();
    p.y = step.pose.t.y();
    p.theta = step.pose.theta;
    p.vx = step.estimate.estimate.twist.v.x();
    p.vy = step.estimate.estimate.twist.v.y();
    p.omega = step.estimate.estimate.twist.omega;
    p.used = step.estimate.estimate.used;
    p.instructions = 0;
    ++emitted;
  };

  q::StreamSummary summary{};
  std::memcpy(summary.magic, q::kOutputMagic, sizeof(summary.magic));
  std::uint64_t pending_ticks = 0;  // pipeline ticks not yet given to a step
  std::uint64_t total_ticks = 0;
  bool ended = false;
  q::StreamRecord r{};
  while (!ended && g_reader->next(r)) {
    emitted = 0;
    std::optional<moa::OdometryError> error;
    const std::uint32_t start = systick();
    switch (r.kind) {
      case q::RecordKind::kMice: {
        moa::SensorRow row;
        row.t = r.t;
        row.sensor = r.sensor;
        row.counts = moa::Vec2(static_cast<moa::real>(r.a), static_cast<moa::real>(r.b));
        if (r.has_squal != 0) row.squal = r.squal;
        row.flags = r.flags;
        row.faults = r.faults;
        error = g_odometry->push(row, sink);
        break;
      }
      case q::RecordKind::kWheels:
        error = g_odometry->push_wheels(
            r.t,
            moa::Twist2{{static_cast<moa::real>(r.a), static_cast<moa::real>(r.b)},
                        static_cast<moa::real>(r.c)},
            sink);
        break;
      case q::RecordKind::kFix: {
        moa::CameraFix fix;
        fix.t = r.t;
        fix.position = moa::Vec2(static_cast<moa::real>(r.a), static_cast<moa::real>(r.b));
        if (r.has_theta != 0) fix.theta = static_cast<moa::real>(r.c);
        if (r.has_sigma != 0)
          fix.sigma = moa::Vec2(static_cast<moa::real>(r.sx), static_cast<moa::real>(r.sy));
        error = g_odometry->push_fix(fix);
        break;
      }
      case q::RecordKind::kEnd:
        g_odometry->finish(r.t, sink);
        ended = true;
        break;
      default:
        fail("input: unknown record kind");
    }
    const std::uint32_t ticks = ticks_between(start, systick());
    total_ticks += ticks;
    pending_ticks += ticks;
    if (error) ++summary.refused_rows;
    if (emitted != 0) {
      // The calls since the previous step go to the first step of this one.
      if (q::StreamPose* first = g_writer->recent(emitted - 1)) {
        first->instructions = static_cast<std::uint32_t>(pending_ticks * per_tick);
      }
      pending_ticks = 0;
    }
    summary.steps += emitted;
  }
  if (!ended) fail("input: no end record");
  g_writer->flush();

  summary.pipeline_instructions = total_ticks * per_tick;
  summary.calibration_instructions = 2 * kLoop;
  summary.calibration_ticks = calibration;
  const std::uint32_t* const low = stack_low_water();
  summary.stack_bytes = static_cast<std::uint64_t>(__stack_top - low) * sizeof(std::uint32_t);
  summary.pipeline_stack_bytes = static_cast<std::uint64_t>(main_sp - low) * sizeof(std::uint32_t);
  if (!sh::write(out, &summary, sizeof(summary))) fail("output: write failed");
  sh::close(out);
  sh::close(in);

  sh::print("odometry_qemu: ");
  print_unsigned(summary.steps);
  sh::print(" steps, ");
  print_unsigned(summary.pipeline_instructions);
  sh::print(" instructions in the pipeline, ");
  print_unsigned(summary.steps == 0 ? 0 : summary.pipeline_instructions / summary.steps);
  sh::print(" per step (SysTick: ");
  print_unsigned(calibration);
  sh::print(" ticks for 2000000 instructions, ");
  print_unsigned(per_tick);
  sh::print(" per tick); stack ");
  print_unsigned(summary.stack_bytes);
  sh::print(" bytes, ");
  print_unsigned(summary.pipeline_stack_bytes);
  sh::print(" of them below this program's main frame\n");
  sh::exit(true);
}
