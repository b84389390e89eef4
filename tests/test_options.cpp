// Every field of OdometryOptions (and of every struct nested in it) is
// checked by validate(), whose message names the field's full path, the
// bound it breaks and the value: one row per field and broken bound.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "moa/calibration/guided_steps.hpp"
#include "moa/core/odometry.hpp"
#include "moa/core/options_check.hpp"
#include "moa/runs/calibration_run.hpp"

namespace moa {
namespace {

std::string message(const OptionCheck& check) { return check ? check->message() : ""; }

// printf's %.6g: the independent rendering of a number the messages use.
std::string g6(double x) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.6g", x);
  return buffer;
}

TEST(InvalidOption, NumbersAreWrittenAsPrintfG6AndWholeNumbersWhole) {
  const std::vector<double> values = {
      0.5,     13.8155, 16.2662,  1e-12,      1e-3,      0.0003,   1e-5,     1e300,     -1e20,
      -2.5e-7, 0.61,    999999.5, 0.00012345, 1.0 / 3.0, -1.0 / 7, 123456.7, 1234567.8, 2.5e15};
  for (const double x : values) {
    InvalidOption e;
    e.append_number(x);
    EXPECT_EQ(std::string(e.message()), g6(x)) << x;
  }
  for (const long long n : {0LL, 1LL, -1LL, 65535LL, 16777216LL, 2000000LL, -999999999999999LL}) {
    InvalidOption e;
    e.append_number(static_cast<double>(n));
    EXPECT_EQ(std::string(e.message()), std::to_string(n)) << n;
  }
  InvalidOption special;
  special.append_number(std::numeric_limits<double>::quiet_NaN());
  special.append(" ");
  special.append_number(-std::numeric_limits<double>::infinity());
  special.append(" ");
  special.append_integer(std::numeric_limits<long long>::min());
  EXPECT_EQ(std::string(special.message()), "nan -inf -9223372036854775808");
}

TEST(InvalidOption, ALongMessageIsCutNotOverrun) {
  InvalidOption e;
  for (int i = 0; i < 100; ++i) e.append("abcdefgh");
  EXPECT_EQ(std::string(e.message()).size(), InvalidOption::kCapacity - 1);
}

TEST(OdometryOptions, DefaultsAreValid) { EXPECT_EQ(message(OdometryOptions{}.validate()), ""); }

struct Case {
  const char* path;                             // as the user sees it
  std::function<void(OdometryOptions&)> apply;  // breaks the field
  std::string must;                             // "must be BOUND, is VALUE"
};

TEST(OdometryOptions, EveryFieldIsCheckedNamingPathBoundAndValue) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const std::string finite_nan = "must be finite, is nan";
  const std::string finite_inf = "must be finite, is inf";
  const std::vector<Case> cases = {
      {"estimator", [](auto& o) { o.estimator = static_cast<EstimatorKind>(9); },
       "must be one of ls (0), sekimori (1), consensus (2), wheels (3), oracle (4), is 9"},
      {"sensors", [](auto& o) { o.sensors = 0; }, "no sensor selected"},
      {"rate", [](auto& o) { o.rate = -1; }, "must be > 0, is -1"},
      {"rate", [&](auto& o) { o.rate = nan; }, finite_nan},
      {"max_row_interval", [](auto& o) { o.max_row_interval = 0; }, "must be > 0, is 0"},
      {"max_row_interval", [&](auto& o) { o.max_row_interval = nan; }, finite_nan},
      // 61 epochs of 1/100 s.
      {"max_row_interval", [](auto& o) { o.max_row_interval = 1; },
       "must be <= 61 periods (" + g6(61 * 0.01) + "), is 1"},
      {"max_gap", [](auto& o) { o.max_gap = 0; }, "must be > 0, is 0"},
      {"max_gap", [&](auto& o) { o.max_gap = nan; }, "must be > 0, is nan"},
      {"initial.x",
       [&](auto& o) {
         o.initial = Pose2{{nan, 0}, 0};
       },
       finite_nan},
      {"initial.y",
       [&](auto& o) {
         o.initial = Pose2{{0, inf}, 0};
       },
       finite_inf},
      {"initial.theta",
       [&](auto& o) {
         o.initial = Pose2{{0, 0}, nan};
       },
       finite_nan},
      {"camera_latency", [](auto& o) { o.camera_latency = -61; }, "must be in [-60, 60], is -61"},
      {"wheels_latency", [](auto& o) { o.wheels_latency = 60.5; }, "must be in [-60, 60], is 60.5"},
      {"camera_latency", [&](auto& o) { o.camera_latency = inf; }, finite_inf},
      {"camera_sigma", [](auto& o) { o.camera_sigma = 0; }, "must be > 0, is 0"},
      {"camera_heading_sigma", [&](auto& o) { o.camera_heading_sigma = nan; }, finite_nan},
      {"sekimori.e_th", [](auto& o) { o.sekimori.e_th = -1; }, "must be > 0, is -1"},
      {"sekimori.r_th", [](auto& o) { o.sekimori.r_th = 0; },
       "must be -1 (automatic) or in [1, 16], is 0"},
      {"sekimori.r_th", [](auto& o) { o.sekimori.r_th = 17; },
       "must be -1 (automatic) or in [1, 16], is 17"},
      {"sekimori.wheels.base_v", [](auto& o) { o.sekimori.wheels.base_v = 0; },
       "must be > 0, is 0"},
      {"sekimori.wheels.base_omega", [&](auto& o) { o.sekimori.wheels.base_omega = nan; },
       finite_nan},
      {"sekimori.wheels.relative", [](auto& o) { o.sekimori.wheels.relative = -0.1; },
       "must be >= 0, is -0.1"},
      {"sekimori.hold.accel", [](auto& o) { o.sekimori.hold.accel = -2; }, "must be > 0, is -2"},
      {"sekimori.hold.angular_accel", [&](auto& o) { o.sekimori.hold.angular_accel = inf; },
       finite_inf},
      {"consensus.alpha", [](auto& o) { o.consensus.alpha = 0; }, "must be in (0, 0.5), is 0"},
      {"consensus.alpha", [](auto& o) { o.consensus.alpha = 0.5; }, "must be in (0, 0.5), is 0.5"},
      {"consensus.alpha", [&](auto& o) { o.consensus.alpha = nan; }, finite_nan},
      {"consensus.noise.relative", [](auto& o) { o.consensus.noise.relative = -1; },
       "must be >= 0, is -1"},
      {"consensus.noise.speed_onset", [](auto& o) { o.consensus.noise.speed_onset = 0; },
       "must be > 0, is 0"},
      {"consensus.noise.speed_cap", [](auto& o) { o.consensus.noise.speed_cap = 0.5; },
       "must be >= 1, is 0.5"},
      {"consensus.noise.min_squal", [](auto& o) { o.consensus.noise.min_squal = -1; },
       "must be in [0, 255], is -1"},
      {"consensus.noise.min_squal", [](auto& o) { o.consensus.noise.min_squal = 256; },
       "must be in [0, 255], is 256"},
      {"consensus.noise.low_squal_factor",
       [](auto& o) { o.consensus.noise.low_squal_factor = 0.5; }, "must be >= 1, is 0.5"},
      {"consensus.noise.overflow_factor", [&](auto& o) { o.consensus.noise.overflow_factor = nan; },
       finite_nan},
      {"consensus.wheels.base_v", [](auto& o) { o.consensus.wheels.base_v = -1; },
       "must be > 0, is -1"},
      {"consensus.wheels.base_omega", [](auto& o) { o.consensus.wheels.base_omega = 0; },
       "must be > 0, is 0"},
      {"consensus.wheels.relative", [&](auto& o) { o.consensus.wheels.relative = inf; },
       finite_inf},
      {"consensus.hold.accel", [](auto& o) { o.consensus.hold.accel = 0; }, "must be > 0, is 0"},
      {"consensus.hold.angular_accel", [](auto& o) { o.consensus.hold.angular_accel = -5; },
       "must be > 0, is -5"},
      {"consensus.limits.accel", [](auto& o) { o.consensus.limits.accel = 0; },
       "must be > 0, is 0"},
      {"consensus.limits.angular_accel", [&](auto& o) { o.consensus.limits.angular_accel = nan; },
       finite_nan},
      {"consensus.health.drift_min_speed",
       [&](auto& o) { o.consensus.health.drift_min_speed = inf; }, finite_inf},
      {"consensus.health.drift_shift", [](auto& o) { o.consensus.health.drift_shift = 0; },
       "must be > 0, is 0"},
      {"consensus.health.drift_false_alarm_time",
       [&](auto& o) { o.consensus.health.drift_false_alarm_time = nan; }, finite_nan},
      {"consensus.health.drift_release_time",
       [](auto& o) { o.consensus.health.drift_release_time = -1; }, "must be > 0, is -1"},
      {"consensus.health.probation", [&](auto& o) { o.consensus.health.probation = nan; },
       finite_nan},
      {"ekf.scale_sd[0]", [](auto& o) { o.ekf.scale_sd.x() = 0; }, "must be > 0, is 0"},
      {"ekf.scale_sd[1]", [&](auto& o) { o.ekf.scale_sd.y() = nan; }, finite_nan},
      {"ekf.scale_random_walk[0]", [](auto& o) { o.ekf.scale_random_walk.x() = -1e-3; },
       "must be >= 0, is -0.001"},
      {"ekf.twist_noise_floor[2]", [](auto& o) { o.ekf.twist_noise_floor.z() = -1; },
       "must be >= 0, is -1"},
      {"ekf.twist_noise_relative", [](auto& o) { o.ekf.twist_noise_relative = -0.05; },
       "must be >= 0, is -0.05"},
      {"ekf.max_consecutive_rejections", [](auto& o) { o.ekf.max_consecutive_rejections = 0; },
       "must be >= 1, is 0"},
      {"ekf.alpha", [](auto& o) { o.ekf.alpha = 0.6; }, "must be in [0, 0.5], is 0.6"},
      {"ekf.estimate_scale", [](auto& o) { o.ekf.estimate_scale = true; },
       "needs fuse_camera (the scales are estimated from camera fixes)"},
      {"self_calibration.gauge",
       [](auto& o) { o.self_calibration.gauge = static_cast<SelfCalibrationGauge>(5); },
       "must be sensors (0) or wheels (1), is 5"},
      {"self_calibration.block", [](auto& o) { o.self_calibration.block = 0; },
       "must be > 0, is 0"},
      {"self_calibration.min_speed", [](auto& o) { o.self_calibration.min_speed = -1; },
       "must be >= 0, is -1"},
      {"self_calibration.scale_walk", [](auto& o) { o.self_calibration.scale_walk = -1; },
       "must be >= 0, is -1"},
      {"self_calibration.yaw_walk", [&](auto& o) { o.self_calibration.yaw_walk = nan; },
       finite_nan},
      {"self_calibration.prior_scale_sd", [](auto& o) { o.self_calibration.prior_scale_sd = 0; },
       "must be > 0, is 0"},
      {"self_calibration.prior_yaw_sd", [](auto& o) { o.self_calibration.prior_yaw_sd = -0.5; },
       "must be > 0, is -0.5"},
      {"self_calibration.relative_noise", [](auto& o) { o.self_calibration.relative_noise = -1; },
       "must be >= 0, is -1"},
      {"self_calibration.apply_alpha", [](auto& o) { o.self_calibration.apply_alpha = 0; },
       "must be in (0, 1), is 0"},
      {"self_calibration.mount_position_sigma",
       [&](auto& o) { o.self_calibration.mount_position_sigma = nan; }, finite_nan},
      {"self_calibration.gross_alpha", [](auto& o) { o.self_calibration.gross_alpha = 1; },
       "must be in (0, 1), is 1"},
      {"self_calibration.predictor_alpha", [](auto& o) { o.self_calibration.predictor_alpha = 1; },
       "must be in (0, 1), is 1"},
      {"self_calibration.runaway_scale", [](auto& o) { o.self_calibration.runaway_scale = 1.5; },
       "must be in (0, 1), is 1.5"},
      {"self_calibration.runaway_yaw", [](auto& o) { o.self_calibration.runaway_yaw = 0; },
       "must be > 0, is 0"},
      {"self_calibration.runaway_alpha", [](auto& o) { o.self_calibration.runaway_alpha = 0.5; },
       "must be in (0, 0.5), is 0.5"},
      {"self_calibration.reset_false_alarm_time",
       [](auto& o) { o.self_calibration.reset_false_alarm_time = 0; }, "must be > 0, is 0"},
      {"self_calibration.reset_rate", [](auto& o) { o.self_calibration.reset_rate = 0.0005; },
       "must be in (0.001, 1), is 0.0005"},
      {"self_calibration.reset_scale_sd", [&](auto& o) { o.self_calibration.reset_scale_sd = nan; },
       finite_nan},
      {"self_calibration.reset_yaw_sd", [](auto& o) { o.self_calibration.reset_yaw_sd = -1; },
       "must be > 0, is -1"},
      {"self_calibration.settle_time", [](auto& o) { o.self_calibration.settle_time = 0; },
       "must be > 0, is 0"},
      {"self_calibration.hold_alpha", [](auto& o) { o.self_calibration.hold_alpha = 1; },
       "must be in (0, 1), is 1"},
      {"self_calibration.repeat_run", [](auto& o) { o.self_calibration.repeat_run = 1; },
       "must be >= 2, is 1"},
      {"self_calibration.apply_step", [](auto& o) { o.self_calibration.apply_step = -1; },
       "must be >= 0, is -1"},
      {"self_calibration.gauge_walk", [](auto& o) { o.self_calibration.gauge_walk = -1; },
       "must be >= 0, is -1"},
      {"self_calibration.wheel_noise", [&](auto& o) { o.self_calibration.wheel_noise = nan; },
       finite_nan},
  };
  for (const Case& c : cases) {
    OdometryOptions o;
    c.apply(o);
    EXPECT_EQ(message(o.validate()), std::string(c.path) + ": " + c.must);
  }
}

TEST(OdometryOptions, BoundsAreInclusiveWhereTheyAreStatedSo) {
  const auto valid = [](const std::function<void(OdometryOptions&)>& apply) {
    OdometryOptions o;
    apply(o);
    return message(o.validate());
  };
  // A long max_row_interval is fine at a low rate: the bound is in epochs.
  EXPECT_EQ(valid([](auto& o) {
              o.rate = 10;
              o.max_row_interval = 6.1;
            }),
            "");
  EXPECT_EQ(valid([](auto& o) { o.max_gap = std::numeric_limits<double>::infinity(); }), "");
  EXPECT_EQ(valid([](auto& o) { o.ekf.scale_random_walk.setZero(); }), "");
  EXPECT_EQ(valid([](auto& o) { o.sekimori.r_th = 16; }), "");
  EXPECT_EQ(valid([](auto& o) { o.consensus.noise.speed_cap = 1; }), "");
  EXPECT_EQ(valid([](auto& o) {
              o.fuse_camera = true;
              o.ekf.estimate_scale = true;
            }),
            "");
}

// The self-calibration's apply test: NaN in its rate is refused by name
// (mount_position_sigma's NaN has its row in the table above).
TEST(OdometryOptions, ANaNFalseAlarmRateIsRefusedByName) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const auto& [name, set] :
       std::vector<std::pair<std::string, std::function<void(SelfCalibrationOptions&)>>>{
           {"apply_alpha", [&](auto& c) { c.apply_alpha = nan; }},
           {"hold_alpha", [&](auto& c) { c.hold_alpha = nan; }}}) {
    OdometryOptions o;
    set(o.self_calibration);
    const std::string m = message(o.validate());
    EXPECT_EQ(m.rfind("self_calibration." + name + ": ", 0), 0u) << m;
    EXPECT_NE(m.find("nan"), std::string::npos) << m;
  }
}

TEST(OptionsCheck, ANestedStructNamesItsFieldsRelativeToItself) {
  HealthOptions h;
  h.drift_shift = 0;
  EXPECT_EQ(message(h.validate()), "drift_shift: must be > 0, is 0");
  RobotLimits limits;
  limits.accel = -1;
  EXPECT_EQ(message(limits.validate()), "accel: must be > 0, is -1");
  // The synchroniser's own bound, the one OdometryOptions reports.
  SynchroniserOptions s;
  s.period = 0.1;
  s.max_row_interval = 7;
  EXPECT_EQ(message(s.validate()),
            "max_row_interval: must be <= 61 periods (" + g6(6.1) + "), is 7");
}

TEST(MotionLimits, EveryFieldIsCheckedNamingBoundAndValue) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(message(MotionLimits{}.validate()), "");
  struct LimitCase {
    std::function<void(MotionLimits&)> apply;
    std::string expected;
  };
  const std::vector<LimitCase> cases = {
      {[&](auto& l) { l.distance = nan; }, "distance: must be finite, is nan"},
      {[](auto& l) { l.distance = 0; }, "distance: must be > 0, is 0"},
      {[](auto& l) { l.turns = 0; }, "turns: must be != 0, is 0"},
      {[&](auto& l) { l.turns = nan; }, "turns: must be finite, is nan"},
      {[](auto& l) { l.distance_tolerance = 1; }, "distance_tolerance: must be in (0, 1), is 1"},
      {[](auto& l) { l.max_off_axis = -1; }, "max_off_axis: must be > 0, is -1"},
      {[](auto& l) { l.max_deviation = 0; }, "max_deviation: must be > 0, is 0"},
      {[&](auto& l) { l.max_heading_change = nan; }, "max_heading_change: must be finite, is nan"},
      {[](auto& l) { l.turn_tolerance = 0; }, "turn_tolerance: must be > 0, is 0"},
      {[](auto& l) { l.max_spin_offset = -0.5; }, "max_spin_offset: must be > 0, is -0.5"},
      {[](auto& l) { l.max_speed_fraction = 0; }, "max_speed_fraction: must be > 0, is 0"},
      {[](auto& l) { l.still_speed = 0; }, "still_speed: must be > 0, is 0"},
      {[](auto& l) { l.still_rate = -2; }, "still_rate: must be > 0, is -2"},
      {[](auto& l) { l.still_time = 0; }, "still_time: must be > 0, is 0"},
  };
  for (const auto& c : cases) {
    MotionLimits l;
    c.apply(l);
    EXPECT_EQ(message(l.validate()), c.expected);
  }
  // A negative number of turns is a direction, not an error.
  MotionLimits clockwise;
  clockwise.turns = -3;
  EXPECT_EQ(message(clockwise.validate()), "");
}

TEST(CalibrationOptions, EveryFieldIsCheckedNamingPathBoundAndValue) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(message(io::CalibrationOptions{}.validate()), "");
  struct CalibrationCase {
    std::function<void(io::CalibrationOptions&)> apply;
    std::string expected;
  };
  const std::vector<CalibrationCase> cases = {
      {[](auto& o) { o.max_row_interval = 0; }, "max_row_interval: must be > 0, is 0"},
      {[&](auto& o) { o.max_row_interval = nan; }, "max_row_interval: must be finite, is nan"},
      {[](auto& o) { o.min_interval = -0.5; }, "min_interval: must be >= 0, is -0.5"},
      {[](auto& o) { o.measurements = -1; }, "measurements: must be >= 0, is -1"},
      {[](auto& o) { o.distance = 0; }, "distance: must be > 0, is 0"},
      {[](auto& o) { o.turns = 0; }, "turns: must be != 0, is 0"},
      {[&](auto& o) { o.turns = nan; }, "turns: must be finite, is nan"},
      {[](auto& o) { o.tolerances.distance_sd = 0; }, "tolerances.distance_sd: must be > 0, is 0"},
      {[](auto& o) { o.tolerances.turn_sd = -1; }, "tolerances.turn_sd: must be > 0, is -1"},
      {[&](auto& o) { o.tolerances.centre_sd = nan; },
       "tolerances.centre_sd: must be finite, is nan"},
      {[](auto& o) { o.tolerances.heading_sd = 0; }, "tolerances.heading_sd: must be > 0, is 0"},
      {[](auto& o) { o.tolerances.anisotropy_sd = -0.02; },
       "tolerances.anisotropy_sd: must be > 0, is -0.02"},
  };
  for (const auto& c : cases) {
    io::CalibrationOptions o;
    c.apply(o);
    EXPECT_EQ(message(o.validate()), c.expected);
  }
}

}  // namespace
}  // namespace moa
