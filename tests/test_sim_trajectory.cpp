// The simulator's motion: paths, profiles, scripted twists, the SE(2) step.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "moa/sim/scenario.hpp"
#include "moa/sim/simulate.hpp"
#include "moa/sim/trajectory.hpp"

namespace moa::sim {
namespace {

constexpr double kPi = std::numbers::pi;

// Sekimori & Miyazaki Table 3, typed in from the paper (mm -> m).
const std::vector<Pose2> kTable3 = {
    {{0.0, 0.0}, 0.0}, {{0.5, 0.0}, 0.0}, {{0.5, 0.0}, kPi / 2}, {{0.5, 0.5}, kPi / 2},
    {{0.5, 0.5}, 0.0}, {{1.0, 0.5}, 0.0}, {{1.0, 0.5}, kPi / 2}, {{1.0, 1.0}, kPi / 2},
    {{1.0, 1.0}, 0.0}, {{1.5, 1.0}, 0.0}};

TEST(SimTrajectory, TrapezoidCoversUnitDistanceWithinLimits) {
  // Closed forms: cruise reached iff rate^2 / accel < 1; duration then
  // 1/rate + rate/accel, else 2 sqrt(1/accel).
  for (const auto& [rate, accel] :
       {std::pair{0.5, 2.0}, std::pair{3.0, 2.0}, std::pair{1.0, 1.0}}) {
    const Trapezoid p(rate, accel);
    const double expected =
        rate * rate / accel < 1.0 ? 1.0 / rate + rate / accel : 2.0 * std::sqrt(1.0 / accel);
    EXPECT_NEAR(p.duration(), expected, 1e-12);
    EXPECT_EQ(p.position(0.0), 0.0);
    EXPECT_EQ(p.position(p.duration()), 1.0);
    const double h = 1e-4;
    double prev_rate = 0.0;
    for (double t = h; t < p.duration(); t += h) {
      const double r = (p.position(t) - p.position(t - h)) / h;
      EXPECT_LE(r, rate + 1e-9);
      // The rate changes by at most accel per unit time (plus the kink at
      // a phase change, which finite differences smear over one step).
      EXPECT_LE(std::abs(r - prev_rate), accel * h * 1.0001 + 1e-12);
      prev_rate = r;
    }
  }
}

TEST(SimTrajectory, Table3PathEndsExactlyAtLastWaypoint) {
  for (const char* name : {"sekimori-a", "sekimori-b"}) {
    const Scenario s = load_scenario(name);
    const auto& path = std::get<WaypointPath>(s.motion);
    ASSERT_EQ(path.waypoints().size(), kTable3.size());
    for (std::size_t i = 0; i < kTable3.size(); ++i) {
      // The scenario's table is the paper's, and the path rests on each
      // waypoint exactly when it arrives.
      EXPECT_NEAR(path.waypoints()[i].t.x(), kTable3[i].t.x(), 1e-15) << name << " " << i;
      EXPECT_NEAR(path.waypoints()[i].t.y(), kTable3[i].t.y(), 1e-15) << name << " " << i;
      EXPECT_NEAR(path.waypoints()[i].theta, kTable3[i].theta, 1e-15) << name << " " << i;
      const Pose2 at = path.pose(path.arrival_time(i));
      EXPECT_EQ(at.t, path.waypoints()[i].t);
      EXPECT_EQ(at.theta, path.waypoints()[i].theta);
    }
    const SimLog log = simulate(s, 1);
    const Pose2& end = log.truth.back().pose;
    EXPECT_EQ(end.t.x(), 1.5) << name;
    EXPECT_EQ(end.t.y(), 1.0) << name;
    EXPECT_EQ(end.theta, 0.0) << name;
  }
}

TEST(SimTrajectory, Table3SpeedsReachButNeverExceedTheLimits) {
  // Speed (a) 0.3 m/s and 1.82 rad/s, (b) 0.5 m/s and 3.03 rad/s: the
  // truth's twists reach them (every segment is long enough to cruise) and
  // stay within them.
  for (const auto& [name, v, w] :
       {std::tuple{"sekimori-a", 0.3, 1.82}, std::tuple{"sekimori-b", 0.5, 3.03}}) {
    const SimLog log = simulate(load_scenario(name), 1);
    double max_v = 0.0, max_w = 0.0;
    for (const auto& r : log.truth) {
      max_v = std::max(max_v, r.twist.v.norm());
      max_w = std::max(max_w, std::abs(r.twist.omega));
      // Pure translation or pure rotation, never both.
      EXPECT_LT(std::min(r.twist.v.norm(), std::abs(r.twist.omega)), 1e-9);
    }
    EXPECT_NEAR(max_v, v, 1e-6) << name;
    EXPECT_NEAR(max_w, w, 1e-6) << name;
  }
}

TEST(SimTrajectory, ArcPathHasNoSidewaysVelocity) {
  const Scenario s = load_scenario("differential");
  const auto& path = std::get<WaypointPath>(s.motion);
  MotionStepper stepper(s.motion);
  const double h = 1.0 / s.sensor_model.frame_rate;
  for (std::int64_t k = 0; k < s.frame_count(); ++k) {
    const auto step = stepper.advance(static_cast<double>(k) * h, static_cast<double>(k + 1) * h);
    ASSERT_LT(std::abs(step.twist.v.y()), 1e-9) << "frame " << k;
  }
  EXPECT_NEAR(stepper.pose().t.x(), path.waypoints().back().t.x(), 1e-15);
  EXPECT_NEAR(stepper.pose().theta, 2.0 * kPi, 1e-15);
}

TEST(SimTrajectory, TwistProgramIntegratesExactly) {
  // Constant twists with instant switches: the truth is exp() of each.
  TwistProgram program;
  program.segments = {{{{0.2, 0.1}, 0.5}, 1.0}, {{{-0.1, 0.3}, -1.2}, 0.5}};
  const Motion motion = program;
  MotionStepper stepper(motion);
  const double h = 1.0 / 1000.0;
  for (int k = 0; k < 1500; ++k) stepper.advance(k * h, (k + 1) * h);
  const Pose2 expected = exp(program.segments[0].twist, 1.0) * exp(program.segments[1].twist, 0.5);
  EXPECT_NEAR(stepper.pose().t.x(), expected.t.x(), 1e-12);
  EXPECT_NEAR(stepper.pose().t.y(), expected.t.y(), 1e-12);
  EXPECT_NEAR(stepper.pose().theta, expected.theta, 1e-12);
}

TEST(SimTrajectory, AccelerationLimitsRampTheTwist) {
  TwistProgram program;
  program.segments = {{{{0.4, 0.0}, 2.0}, 1.0}};
  program.max_accel = 1.0;
  program.max_angular_accel = 4.0;
  const Motion motion = program;
  MotionStepper stepper(motion);
  const double h = 1e-3;
  Twist2 prev;
  for (int k = 0; k < 1000; ++k) {
    const auto step = stepper.advance(k * h, (k + 1) * h);
    EXPECT_LE((step.twist.v - prev.v).norm(), 1.0 * h + 1e-12);
    EXPECT_LE(std::abs(step.twist.omega - prev.omega), 4.0 * h + 1e-12);
    prev = step.twist;
  }
  EXPECT_NEAR(prev.v.x(), 0.4, 1e-12);  // reached after 0.4 s
  EXPECT_NEAR(prev.omega, 2.0, 1e-12);  // after 0.5 s
}

TEST(SimTrajectory, ExcitationStartsAndEndsAtRest) {
  Excitation e;
  e.vx = {{0.3, 0.2, 0.5}};
  e.omega = {{1.0, 0.1, 1.0}};
  e.offset = {{0.1, 0.0}, 0.2};
  e.duration = 10.0;
  e.fade = 1.0;
  EXPECT_EQ(e.twist(0.0).vector().norm(), 0.0);
  EXPECT_NEAR(e.twist(10.0).vector().norm(), 0.0, 1e-15);
  // Between the fades it is the plain sum.
  EXPECT_NEAR(e.twist(5.0).v.x(), 0.1 + 0.3 * std::sin(2 * kPi * 0.2 * 5.0 + 0.5), 1e-12);
  EXPECT_NEAR(e.twist(5.0).omega, 0.2 + std::sin(2 * kPi * 0.1 * 5.0 + 1.0), 1e-12);
}

}  // namespace
}  // namespace moa::sim
