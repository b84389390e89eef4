#include "moa/calibration/guided_session.hpp"

#include <fmt/core.h>

#include <cmath>
#include <limits>

namespace moa {

std::string instructions(GuidedStep step, const MotionLimits& l) {
  switch (step) {
    case GuidedStep::kPushX:
      return fmt::format(
          "Put the robot's side against a straight edge and mark where it starts. Push it {} m "
          "forward (+x) along the edge, without turning it, then hold it still.",
          l.distance);
    case GuidedStep::kPushY:
      return fmt::format(
          "Put the robot's front against the straight edge and mark where it starts. Push it {} m "
          "to its left (+y) along the edge, without turning it, then hold it still.",
          l.distance);
    case GuidedStep::kSpin:
      return fmt::format(
          "Mark a point on the floor under the robot's centre and a line at its front. Spin it "
          "{} whole turn{} {} about that point, stopping where the marks line up, then hold it "
          "still.",
          std::abs(l.turns), std::abs(l.turns) == 1.0 ? "" : "s",
          l.turns > 0 ? "counter-clockwise (seen from above)" : "clockwise (seen from above)");
  }
  return {};
}

std::vector<std::string> guided_result_warnings(const GuidedCalibration& cal, double distance,
                                                const std::vector<std::string>& names) {
  std::vector<std::string> out;
  if (cal.centroid_shift.norm() > 0.003) {
    out.push_back(fmt::format(
        "the sensors' mean position moved by ({:.1f}, {:.1f}) mm from nominal: if the spin was not "
        "about the robot's centre, every position is shifted by that offset",
        cal.centroid_shift.x() * 1e3, cal.centroid_shift.y() * 1e3));
  }
  for (std::size_t i = 0; i < cal.push_misfit.size() && i < names.size(); ++i) {
    if (cal.push_misfit[i] > 0.005 * distance) {
      out.push_back(
          fmt::format("{}: the two pushes disagree with one sensor frame by {:.1f} mm: were they "
                      "perpendicular and without turning?",
                      names[i], cal.push_misfit[i] * 1e3));
    }
  }
  return out;
}

OdometryOptions guided_session_odometry_options() {
  OdometryOptions options;
  options.estimator = EstimatorKind::kConsensus;
  options.use_wheels = false;
  options.max_gap = std::numeric_limits<double>::infinity();
  options.consensus.health.enabled = false;
  options.use_imu = false;  // the gyro is calibrated from the spin, not fused
  return options;
}

GuidedSession::GuidedSession(const SensorArray& nominal, const MotionLimits& limits, bool push_y)
    : limits_(limits), watcher_(nominal, limits), kept_(3) {
  steps_ = {GuidedStep::kPushX};
  if (push_y) steps_.push_back(GuidedStep::kPushY);
  steps_.push_back(GuidedStep::kSpin);
}

void GuidedSession::begin_step() {
  if (complete()) return;
  pending_.reset();
  watcher_.arm(steps_[current_]);
  said_ready_ = said_moving_ = false;
}

GuidedSession::Event GuidedSession::feed(const OdometryStep& epoch) {
  auto summary = watcher_.feed(epoch);
  if (summary) {
    watcher_.disarm();
    pending_ = std::move(summary);
    return Event::kWatched;
  }
  if (watcher_.state() == MotionWatcher::State::kReady && !said_ready_) {
    said_ready_ = true;
    return Event::kReady;
  }
  if (watcher_.state() == MotionWatcher::State::kMoving && !said_moving_) {
    said_moving_ = true;
    return Event::kMoving;
  }
  return Event::kNone;
}

bool GuidedSession::keep(bool force) {
  if (!pending_ || (!pending_->good() && !force)) return false;
  kept_[static_cast<std::size_t>(pending_->step)] = pending_->totals;
  pending_.reset();
  ++current_;
  begin_step();
  return true;
}

bool GuidedSession::redo() {
  if (!pending_) return false;
  begin_step();
  return true;
}

GuidedInput GuidedSession::input() const {
  GuidedInput in;
  in.push_x = kept_[static_cast<std::size_t>(GuidedStep::kPushX)];
  if (steps_.size() == 3) in.push_y = kept_[static_cast<std::size_t>(GuidedStep::kPushY)];
  in.spin = kept_[static_cast<std::size_t>(GuidedStep::kSpin)];
  in.distance = limits_.distance;
  in.turns = limits_.turns;
  return in;
}

}  // namespace moa
