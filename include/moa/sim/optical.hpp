// The simulated optical mouse sensor: the measurement model of
// docs/formats/config.md (SensorMount::counts, the same code the estimators invert),
// frame by frame, with noise, integer counts that carry their remainder, the
// microcontroller's downsampler of K frames, SQUAL, flags, and faults.
//
// Per frame of h = 1 / frame_rate seconds at constant robot twist x:
//   c      = H x h,  H = SensorMount::twist_jacobian()       real counts, sensor frame
//            (SensorMount::counts(x, h), with H computed once per sensor)
//   c_a   += c_a rho n_1 + sigma_f n_2   (each axis a)        relative and additive noise
//   c      = fault(c)                                        see below
//   q      = round(C + c) - round(C),  C += c                integer counts; the fraction
//                                                            stays in C (remainder carried)
//   |q_a| <= delta_limit                                     the 8-bit delta register; a
//                                                            clipped frame sets flag bit 0
// and every K frames the downsampler (moa::Downsampler) emits the sum of the
// K frames' q as one mice.csv row, with one SQUAL reading.
//
// Faults (bits of faults.csv, see docs/simulator.md):
//   tracking loss  (1)  the sensor point's speed |u| above the rated max_speed:
//                       a loss starts with hazard rate (|u|/max_speed - 1) per
//                       second times `rate`, lasts an exponential time of mean
//                       `mean_duration` or until |u| is back under the rating,
//                       and meanwhile only a fraction (uniform in `retained`,
//                       drawn per loss) of the counts is seen. Independent per
//                       sensor. SQUAL times `squal_factor`.
//   liftoff        (2)  zero counts, SQUAL `squal`, flag bit 1 (lift) if `lift_flag`.
//   dirty floor    (4)  counts times `retained`, SQUAL `squal`.
//   spikes         (8)  Poisson (`rate` per second) jumps of `magnitude` counts in a
//                       uniformly random direction, added to one frame.
//   stuck         (16)  the frame's counts frozen at the last frame's before the window.
//   drift         (32)  counts times g(t) = 1 + (scale - 1) min(1, (t - start) / ramp):
//                       a resolution that drifts (dust) or steps (floor change).
// Window faults hold for the frames whose midpoint lies in [start, end).
#pragma once

#include <Eigen/Core>
#include <array>
#include <climits>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "moa/core/sensor.hpp"
#include "moa/sim/random.hpp"

namespace moa::sim {

/// What all sensors of a scenario share: the chip and how it is read.
struct SensorModel {
  std::string preset = kHdns2051.name;
  double cpi = kHdns2051.cpi;                ///< nominal counts per inch
  double max_speed = kHdns2051.max_speed;    ///< m/s, rated tracking speed
  double frame_rate = kHdns2051.frame_rate;  ///< frames per second
  int packets_per_row = 23;                  ///< K: frames summed into one mice.csv row
  double frame_noise = 0.0;                  ///< counts, std. dev. per axis per frame (additive)
  double relative_noise = 0.0;  ///< std. dev. per axis per frame, fraction of the frame's counts
  int delta_limit = 127;        ///< largest |count| per axis per frame; 0: no limit
  double squal = 100.0;         ///< mean SQUAL on the scenario's floor
  double squal_jitter = 0.0;    ///< std. dev. of SQUAL from row to row

  double row_period() const { return static_cast<double>(packets_per_row) / frame_rate; }
};

/// Bits of faults.csv's `faults` column: which faults acted on a row.
enum FaultBit : std::uint8_t {
  kFaultTrackingLoss = 1u << 0,
  kFaultLiftoff = 1u << 1,
  kFaultDirty = 1u << 2,
  kFaultSpike = 1u << 3,
  kFaultStuck = 1u << 4,
  kFaultDrift = 1u << 5,
};
/// "tracking_loss", "liftoff", "dirty", "spikes", "stuck", "drift".
const char* fault_name(FaultBit bit);

struct TrackingLoss {
  double rate = 0.0;            ///< 1/s per unit of relative over-speed (|u| / max_speed - 1)
  double mean_duration = 0.05;  ///< s
  double retained_min = 0.0;    ///< fraction of counts seen while lost, drawn uniformly
  double retained_max = 0.5;
  double squal_factor = 1.0;  ///< SQUAL multiplier on rows with a loss
};

struct FaultWindow {
  FaultBit kind = kFaultLiftoff;  ///< liftoff, dirty, spikes or stuck
  double start = 0.0;             ///< s
  double end = 0.0;               ///< s
  double retained = 0.0;          ///< dirty: fraction of counts seen
  int squal = 0;                  ///< liftoff, dirty: SQUAL reported
  double rate = 0.0;              ///< spikes: per second
  double magnitude = 0.0;         ///< spikes: counts
  bool lift_flag = true;          ///< liftoff: set flag bit 1
  /// drift: the counts' gain goes from 1 to `scale` linearly over `ramp`
  /// seconds from start (0: a step, a change of floor), then stays.
  double scale = 1.0;
  double ramp = 0.0;  ///< s
};

struct SensorFaults {
  std::optional<TrackingLoss> tracking_loss;
  std::vector<FaultWindow> windows;
};

/// Integer counts from real ones with the remainder carried, one axis:
/// after any number of pushes the emitted total is round(sum of pushed
/// counts), so a long run's total is exact to half a count.
class AxisQuantiser {
 public:
  /// Adds real counts, returns the integer counts to emit. Beyond +-limit
  /// (+-INT_MAX when limit is 0) the output is clipped, the excess dropped,
  /// `clipped` set; counts that are not finite are dropped the same way.
  int push(double counts, int limit, bool& clipped) {
    const double bound = limit > 0 ? static_cast<double>(limit) : double{INT_MAX};
    total_ += counts;
    double q = std::round(total_) - emitted_;
    if (!(std::abs(q) <= bound)) {
      const double kept = std::isnan(q) ? 0.0 : std::copysign(bound, q);
      // The counts past the register's range are lost, not delivered later.
      total_ = std::isfinite(q) ? total_ - (q - kept) : emitted_ + kept;
      q = kept;
      clipped = true;
    }
    emitted_ += q;
    return static_cast<int>(q);
  }
  /// Emits exactly `counts` (a stuck register), leaving the remainder as it is.
  void force(int counts) {
    total_ += counts;
    emitted_ += counts;
  }

 private:
  double total_ = 0.0;    ///< real counts seen
  double emitted_ = 0.0;  ///< integer counts emitted (exact in a double)
};

/// Both axes of a sensor.
class CountQuantiser {
 public:
  Eigen::Vector2i push(const Eigen::Vector2d& counts, int limit = 0, bool* clipped = nullptr) {
    bool c = false;
    const Eigen::Vector2i out(x_.push(counts.x(), limit, c), y_.push(counts.y(), limit, c));
    if (clipped && c) *clipped = true;
    return out;
  }
  AxisQuantiser& x() { return x_; }
  AxisQuantiser& y() { return y_; }

 private:
  AxisQuantiser x_;
  AxisQuantiser y_;
};

/// One mice.csv row of a simulated sensor and its fault truth.
struct SensorRowOut {
  Eigen::Vector2i counts{0, 0};
  std::uint8_t squal = 0;
  std::uint8_t flags = 0;       ///< SensorFlag bits (overflow, lift)
  std::uint8_t faults = 0;      ///< FaultBit bits of the faults that acted in the row
  int faulty_frames = 0;        ///< frames of the row with a fault acting
  Eigen::Vector2i clean{0, 0};  ///< the counts without the faults (same noise)
};

class OpticalSensor {
 public:
  /// `mount` is the true sensor (position, yaw, cpi, scale, mirrored,
  /// max_speed); `index` selects its random streams.
  OpticalSensor(const SensorMount& mount, const SensorModel& model, SensorFaults faults,
                std::uint64_t seed, int index);

  /// One frame [t, t + h] at constant robot twist; a row every K frames.
  std::optional<SensorRowOut> frame(const Twist2& twist, double t, double h);

  /// The row a sensor reports at the start (t0, no motion yet).
  SensorRowOut initial_row();

 private:
  std::uint8_t draw_squal();

  SensorMount mount_;
  /// H = SensorMount::twist_jacobian(): counts/s per (vx, vy, omega), once
  /// per sensor; row-major scalars, as the per-frame loop reads them.
  std::array<double, 6> counts_rate_{};
  /// The sensor point's position (m): its speed |v + omega J p| decides tracking loss.
  double px_ = 0.0;
  double py_ = 0.0;
  SensorModel model_;
  SensorFaults faults_;
  Rng noise_rng_;
  Rng fault_rng_;
  Rng squal_rng_;
  /// |counts| per axis per frame: delta_limit, or (0, no register limit)
  /// as many as K frames can sum into a 32-bit row.
  int frame_limit_ = 0;
  CountQuantiser quantiser_;
  CountQuantiser clean_quantiser_;
  Downsampler counts_;              ///< the microcontroller's sum of K frames
  std::array<int, 2> clean_sum_{};  ///< the clean counts of the row so far

  // Tracking loss state.
  bool lost_ = false;
  double lost_remaining_ = 0.0;
  double lost_retained_ = 0.0;
  // Stuck state.
  bool stuck_ = false;
  std::array<int, 2> stuck_value_{};
  std::array<int, 2> last_output_{};

  // The row being accumulated.
  std::uint8_t row_faults_ = 0;
  std::uint8_t row_flags_ = 0;
  int row_faulty_frames_ = 0;
  int row_squal_cap_ = 255;
  bool row_lost_ = false;
};

}  // namespace moa::sim
