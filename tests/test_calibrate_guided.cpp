// Guided calibration: pushes along x and y and a spin, count totals only.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "moa/calibration/guided.hpp"
#include "support/calibration_data.hpp"

namespace moa {
namespace {

constexpr double kPi = std::numbers::pi;

// 1 m along x (or y) at 0.2 m/s, and 5 turns in 10 s about the robot-frame
// point `centre` (v = -omega J centre: the point stays still).
Twist2 push_x(double) { return {{0.2, 0.0}, 0.0}; }
Twist2 push_y(double) { return {{0.0, 0.2}, 0.0}; }
test::TwistScript spin_about(const Eigen::Vector2d& centre, double direction = 1.0) {
  return [centre, direction](double) {
    const double w = direction * 2.0 * kPi * 5.0 / 10.0;
    return Twist2{-w * skew_unit() * centre, w};
  };
}

GuidedInput input_for(const SensorArray& truth, bool with_y,
                      const Eigen::Vector2d& centre = Eigen::Vector2d::Zero()) {
  GuidedInput in;
  in.push_x = test::count_totals(truth, push_x, 5.0);
  if (with_y) in.push_y = test::count_totals(truth, push_y, 5.0);
  in.spin = test::count_totals(truth, spin_about(centre), 10.0);
  in.distance = 1.0;
  in.turns = 5.0;
  return in;
}

GuidedCalibration calibrate(const SensorArray& nominal, const GuidedInput& in,
                            const GuidedTolerances& tol = {}) {
  const auto r = calibrate_guided(nominal, in, tol);
  if (const auto* e = std::get_if<CalibrationError>(&r)) {
    ADD_FAILURE() << describe(*e);
    return {};
  }
  return std::get<GuidedCalibration>(r);
}

// Bounds from quantisation: totals are exact to one count in ~31500 (push,
// 800 cpi) and ~10^5 (spin): 3e-5 relative in M, so ~1e-4 in yaw and scale
// and |p| * 1e-4 = 1e-5 m in position, with margin.
constexpr double kPositionTol = 2e-5;
constexpr double kYawTol = 2e-4;
constexpr double kScaleTol = 2e-4;

TEST(CalibrateGuided, RecoversExtrinsicsFromPushesAndSpin) {
  std::mt19937_64 rng(21);
  const SensorArray nominal = test::four_sensor_nominal();
  const SensorArray truth = test::perturbed(nominal, rng, 0.008, 0.07, 0.04, 1);
  const GuidedCalibration cal = calibrate(nominal, input_for(truth, true));
  for (int i = 0; i < 4; ++i) {
    const SensorMount& m = cal.calibrated[i];
    EXPECT_LT((m.position - truth[i].position).norm(), kPositionTol) << "sensor " << i;
    EXPECT_LT(std::abs(wrap_angle(m.yaw - truth[i].yaw)), kYawTol) << "sensor " << i;
    EXPECT_LT((m.scale - truth[i].scale).cwiseAbs().maxCoeff(), kScaleTol) << "sensor " << i;
    EXPECT_EQ(m.mirrored, truth[i].mirrored) << "sensor " << i;
    EXPECT_TRUE(cal.sensors[static_cast<std::size_t>(i)].mirror_from_data);
  }
  EXPECT_FALSE(cal.isotropic_scale);
  EXPECT_FALSE(cal.spin_clockwise);
}

TEST(CalibrateGuided, SpinAboutAnotherPointShiftsEveryPositionByThatOffset) {
  // C^s = 2 pi K M J (p - c): the data see p - c, whatever c.
  std::mt19937_64 rng(22);
  const SensorArray nominal = test::four_sensor_nominal();
  const SensorArray truth = test::perturbed(nominal, rng, 0.005, 0.05, 0.03);
  const Eigen::Vector2d centre(0.01, -0.02);
  const GuidedCalibration cal = calibrate(nominal, input_for(truth, true, centre));
  for (int i = 0; i < 4; ++i) {
    EXPECT_LT((cal.calibrated[i].position - (truth[i].position - centre)).norm(), kPositionTol)
        << "sensor " << i;
    EXPECT_LT(std::abs(wrap_angle(cal.calibrated[i].yaw - truth[i].yaw)), kYawTol);
  }
  EXPECT_LT((cal.centroid_shift + centre).norm(), 0.01)  // truth's own errors are <= 5 mm
      << "the centroid shift shows the offset";
}

TEST(CalibrateGuided, WithoutPushYIsotropicSensorsAreRecoveredAndMirroringFound) {
  // Without push-y only M e_x is known: exact when sx = sy; the mirroring
  // is the one whose spin position is near the nominal place.
  std::mt19937_64 rng(23);
  const SensorArray nominal = test::four_sensor_nominal();
  SensorArray truth = test::perturbed(nominal, rng, 0.005, 0.05, 0.0, 2);
  for (int i = 0; i < 4; ++i) truth[i].scale = Eigen::Vector2d::Constant(1.0 + 0.01 * i);
  const GuidedCalibration cal = calibrate(nominal, input_for(truth, false));
  EXPECT_TRUE(cal.isotropic_scale);
  for (int i = 0; i < 4; ++i) {
    const SensorMount& m = cal.calibrated[i];
    EXPECT_EQ(m.mirrored, truth[i].mirrored) << "sensor " << i;
    EXPECT_LT((m.position - truth[i].position).norm(), kPositionTol) << "sensor " << i;
    EXPECT_LT(std::abs(wrap_angle(m.yaw - truth[i].yaw)), kYawTol) << "sensor " << i;
    EXPECT_LT((m.scale - truth[i].scale).cwiseAbs().maxCoeff(), kScaleTol) << "sensor " << i;
  }
}

TEST(CalibrateGuided, CalibratedYawKeepsTheNominalsRepresentation) {
  // Nominal yaws written beyond pi come back within pi of themselves, with
  // and without push-y.
  SensorArray nominal = test::four_sensor_nominal();
  nominal[2].yaw += 2.0 * kPi;
  nominal[3].yaw += 2.0 * kPi;
  std::mt19937_64 rng(24);
  SensorArray truth = test::perturbed(nominal, rng, 0.005, 0.05, 0.0, 1);
  for (int i = 0; i < 4; ++i) truth[i].scale = Eigen::Vector2d::Constant(1.0 + 0.01 * i);
  for (const bool with_y : {true, false}) {
    const GuidedCalibration cal = calibrate(nominal, input_for(truth, with_y));
    for (int i = 0; i < 4; ++i) {
      EXPECT_NEAR(cal.calibrated[i].yaw, truth[i].yaw, kYawTol) << "sensor " << i << with_y;
    }
  }
}

TEST(CalibrateGuided, DetectsBackwardPushesAndClockwiseSpin) {
  std::mt19937_64 rng(24);
  const SensorArray nominal = test::four_sensor_nominal();
  const SensorArray truth = test::perturbed(nominal, rng, 0.005, 0.05, 0.03);
  GuidedInput in;
  in.push_x = test::count_totals(
      truth,
      [](double) {
        return Twist2{{-0.2, 0.0}, 0.0};
      },
      5.0);
  in.push_y = test::count_totals(
      truth,
      [](double) {
        return Twist2{{0.0, -0.2}, 0.0};
      },
      5.0);
  in.spin = test::count_totals(truth, spin_about(Eigen::Vector2d::Zero(), -1.0), 10.0);
  in.distance = 1.0;
  in.turns = 5.0;
  const GuidedCalibration cal = calibrate(nominal, in);
  EXPECT_TRUE(cal.push_x_reversed);
  EXPECT_TRUE(cal.push_y_reversed);
  EXPECT_TRUE(cal.spin_clockwise);
  for (int i = 0; i < 4; ++i) {
    EXPECT_LT((cal.calibrated[i].position - truth[i].position).norm(), kPositionTol);
    EXPECT_LT(std::abs(wrap_angle(cal.calibrated[i].yaw - truth[i].yaw)), kYawTol);
  }
}

TEST(CalibrateGuided, SigmaIsTheFirstOrderCostOfEachTolerance) {
  // Sensors aligned with the robot (yaw 0): M = k diag(sx, sy), so a
  // distance error e on push-x scales sx by (1 + e) and p_y = -q_x / (k sx)
  // by 1 / (1 + e); push-y likewise sy and p_x. A spin-centre error c
  // shifts every position by c. Closed forms for the 1-sigma.
  SensorArray nominal = test::kimlee_nominal();
  const GuidedInput in = input_for(nominal, true);
  GuidedTolerances only_distance{0.002, 0.0, 0.0, 0.0, 0.0};
  const GuidedCalibration a = calibrate(nominal, in, only_distance);
  GuidedTolerances only_centre{0.0, 0.0, 0.001, 0.0, 0.0};
  const GuidedCalibration b = calibrate(nominal, in, only_centre);
  for (int i = 0; i < 3; ++i) {
    const auto& ca = a.sensors[static_cast<std::size_t>(i)].covariance;
    const auto& cb = b.sensors[static_cast<std::size_t>(i)].covariance;
    const Eigen::Vector2d p = nominal[i].position;
    // Central differences of a 1/(1+e) dependence: exact to O(e^2) = 4e-6 relative.
    EXPECT_NEAR(std::sqrt(ca(3, 3)), 0.002, 1e-7) << "sensor " << i;
    EXPECT_NEAR(std::sqrt(ca(4, 4)), 0.002, 1e-7);
    EXPECT_NEAR(std::sqrt(ca(0, 0)), std::abs(p.x()) * 0.002, 1e-7);
    EXPECT_NEAR(std::sqrt(ca(1, 1)), std::abs(p.y()) * 0.002, 1e-7);
    EXPECT_NEAR(std::sqrt(cb(0, 0)), 0.001, 1e-9);
    EXPECT_NEAR(std::sqrt(cb(1, 1)), 0.001, 1e-9);
    EXPECT_NEAR(cb(2, 2), 0.0, 1e-18);
    EXPECT_NEAR(cb(3, 3), 0.0, 1e-18);
  }
}

TEST(CalibrateGuided, UnusableInputIsAnError) {
  const SensorArray nominal = test::four_sensor_nominal();
  GuidedInput in = input_for(nominal, true);
  in.distance = 0.0;
  const auto r = calibrate_guided(nominal, in);
  ASSERT_TRUE(std::holds_alternative<CalibrationError>(r));
  EXPECT_EQ(std::get<CalibrationError>(r), CalibrationError::kBadInput);

  in = input_for(nominal, true);
  in.turns = 0.0;
  const auto t = calibrate_guided(nominal, in);
  ASSERT_TRUE(std::holds_alternative<CalibrationError>(t));
  EXPECT_EQ(std::get<CalibrationError>(t), CalibrationError::kBadInput);

  in = input_for(nominal, true);
  in.push_x[2].setZero();
  (*in.push_y)[2].setZero();
  const auto z = calibrate_guided(nominal, in);
  ASSERT_TRUE(std::holds_alternative<CalibrationError>(z));
  EXPECT_EQ(std::get<CalibrationError>(z), CalibrationError::kBadInput);

  in = input_for(nominal, true);
  in.spin.pop_back();
  const auto s = calibrate_guided(nominal, in);
  ASSERT_TRUE(std::holds_alternative<CalibrationError>(s));
  EXPECT_EQ(std::get<CalibrationError>(s), CalibrationError::kTooManySensors);
}

}  // namespace
}  // namespace moa
