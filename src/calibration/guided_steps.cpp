#include "moa/calibration/guided_steps.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace moa {
namespace {

constexpr double kTurn = 2.0 * std::numbers::pi;

}  // namespace

const char* describe(GuidedStep step) {
  switch (step) {
    case GuidedStep::kPushX:
      return "push along x";
    case GuidedStep::kPushY:
      return "push along y";
    case GuidedStep::kSpin:
      return "spin";
  }
  return "?";
}

OptionCheck MotionLimits::validate() const {
  return OptionsCheck()
      .positive("distance", distance)
      .require(std::isfinite(turns), "turns", "finite", turns)
      .require(turns != 0.0, "turns", "!= 0", turns)
      .open("distance_tolerance", distance_tolerance, 0.0, 1.0)
      .positive("max_off_axis", max_off_axis)
      .positive("max_deviation", max_deviation)
      .positive("max_heading_change", max_heading_change)
      .positive("turn_tolerance", turn_tolerance)
      .positive("max_spin_offset", max_spin_offset)
      .positive("max_speed_fraction", max_speed_fraction)
      .positive("still_speed", still_speed)
      .positive("still_rate", still_rate)
      .positive("still_time", still_time)
      .result();
}

MotionWatcher::MotionWatcher(const SensorArray& nominal, const MotionLimits& limits)
    : nominal_(nominal), limits_(limits) {}

void MotionWatcher::arm(GuidedStep step) {
  step_ = step;
  state_ = State::kSettling;
  still_for_ = 0.0;
}

bool MotionWatcher::still(const OdometryStep& epoch) const {
  const Twist2& v = epoch.estimate.estimate.twist;
  return v.v.norm() <= limits_.still_speed && std::abs(v.omega) <= limits_.still_rate;
}

std::optional<MotionSummary> MotionWatcher::feed(const OdometryStep& epoch) {
  if (state_ == State::kIdle || epoch.sample == nullptr) return std::nullopt;
  const ArraySample& sample = *epoch.sample;
  const int n = nominal_.size();
  const bool is_still = still(epoch);
  switch (state_) {
    case State::kIdle:
      return std::nullopt;
    case State::kSettling:
      still_for_ = is_still ? still_for_ + sample.dt : 0.0;
      if (still_for_ >= limits_.still_time) state_ = State::kReady;
      return std::nullopt;
    case State::kReady:
    case State::kMoving:
      break;
  }
  if (state_ == State::kReady) {
    if (is_still) {
      // The motion's totals start with the last still epoch.
      totals_.assign(static_cast<std::size_t>(n), Eigen::Vector2d::Zero());
      for (int i = 0; i < n; ++i)
        totals_[static_cast<std::size_t>(i)] = sample.counts[static_cast<std::size_t>(i)];
      start_ = epoch.pose;
      t_start_ = sample.t - sample.dt;
      path_.assign(1, Eigen::Vector2d::Zero());
      body_ = Eigen::Vector2d::Zero();
      count_paths_.assign(1, totals_);
      rotation_ = epoch.estimate.estimate.twist.omega * sample.dt;
      top_speed_ = 0.0;
      worst_fraction_ = -1.0;
      fast_sensor_ = lifted_sensor_ = -1;
      overflow_ = false;
      return std::nullopt;
    }
    state_ = State::kMoving;
    still_for_ = 0.0;
  }
  for (int i = 0; i < n; ++i) {
    totals_[static_cast<std::size_t>(i)] += sample.counts[static_cast<std::size_t>(i)];
  }
  rotation_ += epoch.estimate.estimate.twist.omega * sample.dt;
  body_ += epoch.estimate.estimate.twist.v * sample.dt;
  count_paths_.push_back(totals_);
  t_last_ = sample.t;
  path_.push_back((start_.inverse() * epoch.pose).t);
  const Twist2& v = epoch.estimate.estimate.twist;
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const SensorMount& m = nominal_[i];
    const Eigen::Vector2d point = v.v + v.omega * Eigen::Vector2d(-m.position.y(), m.position.x());
    const double speed = point.norm();
    if (speed > top_speed_) top_speed_ = speed;
    if (m.max_speed && *m.max_speed > 0.0 && speed / *m.max_speed > worst_fraction_) {
      worst_fraction_ = speed / *m.max_speed;
      if (worst_fraction_ > limits_.max_speed_fraction) fast_sensor_ = i;
    }
    if (sample.flags[k] & kFlagOverflow) {
      overflow_ = true;
      fast_sensor_ = i;
    }
    if (sample.flags[k] & kFlagLift) lifted_sensor_ = i;
  }
  still_for_ = is_still ? still_for_ + sample.dt : 0.0;
  if (still_for_ < limits_.still_time) return std::nullopt;
  state_ = State::kIdle;
  return finish();
}

MotionSummary MotionWatcher::finish() const {
  MotionSummary s;
  s.step = step_;
  s.duration = t_last_ - t_start_;
  // A push is judged in the start frame without the estimated rotation:
  // the nominal mounts' errors show as a false turn (a few degrees), which
  // would otherwise bend the path.
  s.displacement = step_ == GuidedStep::kSpin ? path_.back() : body_;
  s.rotation = rotation_;
  s.top_speed = top_speed_;
  if (worst_fraction_ >= 0.0) s.speed_fraction = worst_fraction_;
  s.fast_sensor = fast_sensor_;
  s.lifted_sensor = lifted_sensor_;
  s.overflow = overflow_;
  s.totals = totals_;
  const Eigen::Vector2d chord = s.displacement;
  double excursion = 0.0;
  for (const auto& p : path_) excursion = std::max(excursion, p.norm());
  // Straightness from each sensor's own counts: a linear map (the sensor's
  // mount, whatever it is) keeps a straight path straight, so this needs no
  // calibration. Deviation as a share of the sensor's chord, times the
  // distance moved.
  const std::size_t n = totals_.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d c = count_paths_.back()[i] - count_paths_.front()[i];
    if (c.norm() < 1.0) continue;
    double worst = 0.0;
    for (const auto& p : count_paths_) {
      const Eigen::Vector2d q = p[i] - count_paths_.front()[i];
      worst = std::max(worst, std::abs(c.x() * q.y() - c.y() * q.x()) / c.norm());
    }
    s.deviation = std::max(s.deviation, worst / c.norm() * chord.norm());
  }
  s.spin_offset = excursion / 2.0;

  auto& problems = s.problems;
  const MotionLimits& l = limits_;
  if (step_ == GuidedStep::kSpin) {
    const double turns = std::abs(s.rotation) / kTurn;
    if (turns < std::abs(l.turns) - l.turn_tolerance)
      problems.push_back(MotionProblem::kTooFewTurns);
    if (turns > std::abs(l.turns) + l.turn_tolerance)
      problems.push_back(MotionProblem::kTooManyTurns);
    if (s.spin_offset > l.max_spin_offset) problems.push_back(MotionProblem::kOffCentre);
  } else {
    const bool x = step_ == GuidedStep::kPushX;
    const double along = std::abs(x ? chord.x() : chord.y());
    const double across = std::abs(x ? chord.y() : chord.x());
    if (along < (1.0 - l.distance_tolerance) * l.distance)
      problems.push_back(MotionProblem::kTooShort);
    if (along > (1.0 + l.distance_tolerance) * l.distance)
      problems.push_back(MotionProblem::kTooLong);
    if (std::atan2(across, along) > l.max_off_axis) problems.push_back(MotionProblem::kOffAxis);
    if (s.deviation > l.max_deviation) problems.push_back(MotionProblem::kNotStraight);
    if (std::abs(s.rotation) > l.max_heading_change) problems.push_back(MotionProblem::kTurned);
  }
  if (s.fast_sensor >= 0) problems.push_back(MotionProblem::kTooFast);
  if (s.lifted_sensor >= 0) problems.push_back(MotionProblem::kLifted);
  return s;
}

std::string summarise(const MotionSummary& m) {
  if (m.step == GuidedStep::kSpin) {
    return fmt::format(
        "{:.2f} turns {} in {:.1f} s, centre {:.1f} mm off, fastest sensor {:.2f} m/s",
        std::abs(m.rotation) / kTurn, m.rotation >= 0 ? "counter-clockwise" : "clockwise",
        m.duration, m.spin_offset * 1e3, m.top_speed);
  }
  const bool x = m.step == GuidedStep::kPushX;
  const double along = x ? m.displacement.x() : m.displacement.y();
  const double across = x ? m.displacement.y() : m.displacement.x();
  return fmt::format(
      "{:.3f} m along {}{}, {:.1f} deg off the axis, {:.1f} mm off a straight line, turned {:.1f} "
      "deg, in {:.1f} s, fastest sensor {:.2f} m/s",
      std::abs(along), x ? 'x' : 'y', along < 0 ? " (backwards)" : "",
      to_degrees(std::atan2(std::abs(across), std::abs(along))), m.deviation * 1e3,
      to_degrees(m.rotation), m.duration, m.top_speed);
}

std::string explain(const MotionSummary& m, MotionProblem problem, const MotionLimits& l) {
  const bool x = m.step == GuidedStep::kPushX;
  const char axis = x ? 'x' : 'y';
  const double along = std::abs(x ? m.displacement.x() : m.displacement.y());
  switch (problem) {
    case MotionProblem::kTooShort:
      return fmt::format("too short: {:.3f} m of the {} m; push the whole distance", along,
                         l.distance);
    case MotionProblem::kTooLong:
      return fmt::format("too long: {:.3f} m of the {} m; stop at the mark", along, l.distance);
    case MotionProblem::kOffAxis:
      return fmt::format(
          "not along {}: {:.1f} deg off the robot's {} axis (at most {:.1f}); keep "
          "its side against the straight edge",
          axis,
          to_degrees(std::atan2(std::abs(x ? m.displacement.y() : m.displacement.x()), along)),
          axis, to_degrees(l.max_off_axis));
    case MotionProblem::kNotStraight:
      return fmt::format(
          "not straight: the path strayed {:.1f} mm from a straight line (at most "
          "{:.1f}); slide it along the straight edge",
          m.deviation * 1e3, l.max_deviation * 1e3);
    case MotionProblem::kTurned:
      return fmt::format(
          "turned while pushing: {:.1f} deg (at most {:.1f}); keep it against the "
          "edge without turning",
          to_degrees(m.rotation), to_degrees(l.max_heading_change));
    case MotionProblem::kTooFewTurns:
    case MotionProblem::kTooManyTurns:
      return fmt::format(
          "{}: {:.2f} turns of the {}; stop where the mark lines up again",
          problem == MotionProblem::kTooFewTurns ? "too few turns" : "too many turns",
          std::abs(m.rotation) / kTurn, std::abs(l.turns));
    case MotionProblem::kOffCentre:
      return fmt::format(
          "off-centre spin: the centre moved about {:.1f} mm from the marked point "
          "(at most {:.1f}); keep the robot's centre on the mark",
          m.spin_offset * 1e3, l.max_spin_offset * 1e3);
    case MotionProblem::kTooFast:
      return m.overflow ? std::string("too fast: a sensor's counter overflowed; move slower")
                        : fmt::format(
                              "too fast: a sensor moved at {:.0f} % of its rated speed (at "
                              "most {:.0f} %); move slower",
                              m.speed_fraction.value_or(0.0) * 100.0, l.max_speed_fraction * 100.0);
    case MotionProblem::kLifted:
      return "a sensor lifted off the floor: keep the robot flat";
  }
  return "?";
}

}  // namespace moa
