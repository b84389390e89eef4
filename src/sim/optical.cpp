#include "moa/sim/optical.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "moa/core/array.hpp"

namespace moa::sim {

const char* fault_name(FaultBit bit) {
  switch (bit) {
    case kFaultTrackingLoss:
      return "tracking_loss";
    case kFaultLiftoff:
      return "liftoff";
    case kFaultDirty:
      return "dirty";
    case kFaultSpike:
      return "spikes";
    case kFaultStuck:
      return "stuck";
    case kFaultDrift:
      return "drift";
  }
  return "unknown";
}

OpticalSensor::OpticalSensor(const SensorMount& mount, const SensorModel& model,
                             SensorFaults faults, std::uint64_t seed, int index)
    : mount_(mount),
      px_(mount.position.x()),
      py_(mount.position.y()),
      model_(model),
      faults_(std::move(faults)),
      noise_rng_(seed, Stream::kSensorNoise, index),
      fault_rng_(seed, Stream::kSensorFaults, index),
      squal_rng_(seed, Stream::kSensorSqual, index),
      frame_limit_(model.delta_limit > 0 ? model.delta_limit
                                         : INT_MAX / std::max(1, model.packets_per_row)),
      counts_(model.packets_per_row) {
  const Eigen::Matrix<double, 2, 3> h = mount.twist_jacobian();
  for (int r = 0; r < 2; ++r) {
    for (int c = 0; c < 3; ++c) counts_rate_[static_cast<std::size_t>(3 * r + c)] = h(r, c);
  }
}

std::uint8_t OpticalSensor::draw_squal() {
  double squal = model_.squal;
  if (model_.squal_jitter > 0.0) squal += model_.squal_jitter * squal_rng_.normal();
  return static_cast<std::uint8_t>(std::clamp(std::round(squal), 0.0, 255.0));
}

SensorRowOut OpticalSensor::initial_row() {
  SensorRowOut row;
  row.squal = draw_squal();
  return row;
}

// The per-frame loop runs ~10^5 times per simulated minute and sensor, so
// it is written on scalars: Eigen's small fixed-size types cost little when
// optimised but a lot in the Debug and sanitizer builds the tests run in.
std::optional<SensorRowOut> OpticalSensor::frame(const Twist2& twist, double t, double h) {
  const double vx = twist.v.x();
  const double vy = twist.v.y();
  const double w = twist.omega;
  // The measurement model, shared with the estimators: SensorMount::counts
  // = twist_jacobian() x dt, with the Jacobian kept (it depends on the mount only).
  const auto& H = counts_rate_;
  std::array<double, 2> c{(H[0] * vx + H[1] * vy + H[2] * w) * h,
                          (H[3] * vx + H[4] * vy + H[5] * w) * h};
  if (mount_.speed_scale.active()) {
    // Speed-dependent resolution: the sensor counts ratio(s) of the true
    // displacement, s = |v + omega J p| (m/s) its point's true ground speed.
    const double ratio = mount_.speed_scale.ratio(std::hypot(vx - w * py_, vy + w * px_));
    c[0] *= ratio;
    c[1] *= ratio;
  }
  if (model_.relative_noise > 0.0 || model_.frame_noise > 0.0) {
    for (double& ca : c) {
      const double relative = model_.relative_noise * noise_rng_.normal();
      const double additive = model_.frame_noise * noise_rng_.normal();
      ca += ca * relative + additive;
    }
  }
  bool ignored = false;
  clean_sum_[0] += clean_quantiser_.x().push(c[0], frame_limit_, ignored);
  clean_sum_[1] += clean_quantiser_.y().push(c[1], frame_limit_, ignored);

  std::uint8_t bits = 0;
  double gain = 1.0;  // fraction of the counts the sensor sees this frame
  const double mid = t + 0.5 * h;

  if (faults_.tracking_loss) {
    const TrackingLoss& loss = *faults_.tracking_loss;
    const double rated = mount_.max_speed.value_or(model_.max_speed);
    const double speed = std::hypot(vx - w * py_, vy + w * px_);
    const double over = speed / rated - 1.0;
    if (lost_) {
      lost_remaining_ -= h;
      if (over <= 0.0 || lost_remaining_ < 0.0) lost_ = false;
    } else if (over > 0.0 && loss.rate > 0.0) {
      const double p = 1.0 - std::exp(-loss.rate * over * h);
      if (fault_rng_.uniform() < p) {
        lost_ = true;
        lost_remaining_ = fault_rng_.exponential(loss.mean_duration);
        lost_retained_ = fault_rng_.uniform(loss.retained_min, loss.retained_max);
      }
    }
    if (lost_) {
      bits |= kFaultTrackingLoss;
      gain *= lost_retained_;
      row_lost_ = true;
    }
  }

  bool lifted = false;
  bool stuck_now = false;
  std::array<double, 2> spike{0.0, 0.0};
  for (const FaultWindow& f : faults_.windows) {
    if (mid < f.start || mid >= f.end) continue;
    switch (f.kind) {
      case kFaultLiftoff:
        lifted = true;
        bits |= kFaultLiftoff;
        row_squal_cap_ = std::min(row_squal_cap_, f.squal);
        if (f.lift_flag) row_flags_ |= kFlagLift;
        break;
      case kFaultDirty:
        bits |= kFaultDirty;
        gain *= f.retained;
        row_squal_cap_ = std::min(row_squal_cap_, f.squal);
        break;
      case kFaultSpike:
        if (fault_rng_.uniform() < f.rate * h) {
          const double angle = 2.0 * std::numbers::pi * fault_rng_.uniform();
          spike[0] += f.magnitude * std::cos(angle);
          spike[1] += f.magnitude * std::sin(angle);
          bits |= kFaultSpike;
        }
        break;
      case kFaultStuck:
        stuck_now = true;
        bits |= kFaultStuck;
        break;
      case kFaultDrift:
        bits |= kFaultDrift;
        gain *=
            1.0 + (f.scale - 1.0) * (f.ramp > 0.0 ? std::min(1.0, (mid - f.start) / f.ramp) : 1.0);
        break;
      case kFaultTrackingLoss:
        break;
    }
  }
  if (lifted) gain = 0.0;

  std::array<int, 2> out{};
  if (stuck_now) {
    if (!stuck_) stuck_value_ = last_output_;
    out = stuck_value_;
    quantiser_.x().force(out[0]);
    quantiser_.y().force(out[1]);
  } else {
    bool clipped = false;
    out[0] = quantiser_.x().push(gain * c[0] + (lifted ? 0.0 : spike[0]), frame_limit_, clipped);
    out[1] = quantiser_.y().push(gain * c[1] + (lifted ? 0.0 : spike[1]), frame_limit_, clipped);
    if (clipped) row_flags_ |= kFlagOverflow;
  }
  stuck_ = stuck_now;
  last_output_ = out;

  row_faults_ |= bits;
  if (bits != 0) ++row_faulty_frames_;
  const auto emitted = counts_.push(out[0], out[1]);
  if (!emitted) return std::nullopt;

  SensorRowOut row;
  row.counts = *emitted;
  row.clean = {clean_sum_[0], clean_sum_[1]};
  clean_sum_ = {0, 0};
  double squal = draw_squal();
  if (row_lost_) squal = std::round(squal * faults_.tracking_loss->squal_factor);
  row.squal = static_cast<std::uint8_t>(
      std::clamp(std::min(squal, static_cast<double>(row_squal_cap_)), 0.0, 255.0));
  row.flags = row_flags_;
  row.faults = row_faults_;
  row.faulty_frames = row_faulty_frames_;
  row_faults_ = 0;
  row_flags_ = 0;
  row_faulty_frames_ = 0;
  row_squal_cap_ = 255;
  row_lost_ = false;
  return row;
}

}  // namespace moa::sim
