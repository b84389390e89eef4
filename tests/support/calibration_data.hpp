// Calibration test data: reference samples from the noise-free synthesiser,
// wheels.csv with noise, and robots with known mounting errors.
#pragma once

#include <cstdint>
#include <filesystem>
#include <random>
#include <vector>

#include "moa/calibration/calibrate.hpp"
#include "support/synth.hpp"

namespace moa::test {

/// Noise of the simulated reference (wheel odometry), white, per row.
struct ReferenceNoise {
  double speed = 0.0;  ///< m/s, on vx and vy
  double rate = 0.0;   ///< rad/s, on omega
};

/// The twist averaged over (t0, t1] of a script (midpoint rule, `substep` s).
Twist2 average_twist(const TwistScript& script, double t0, double t1, double substep = 1e-4);

/// Samples with rows every `period` s over `duration` s: counts of `truth`
/// from synthesise() (integers when `quantise`; substeps of period / 8),
/// paired with the script's average twist over each row on the same
/// substeps plus `noise` (seeded), through IntervalAccumulator.
std::vector<CalibrationSample> reference_samples(const SensorArray& truth,
                                                 const TwistScript& script, double duration,
                                                 double period, bool quantise,
                                                 ReferenceNoise noise = {}, std::uint64_t seed = 1);

/// Writes wheels.csv (t,vx,vy,omega) with the average twist over each row
/// interval of `period` s plus noise; the first row at t = 0 opens.
void write_wheels(const std::filesystem::path& dir, const TwistScript& script, double duration,
                  double period, ReferenceNoise noise = {}, std::uint64_t seed = 1,
                  double substep = 1e-4);

/// Count totals per sensor of a scripted motion (quantised rows summed).
std::vector<Eigen::Vector2d> count_totals(const SensorArray& truth, const TwistScript& script,
                                          double duration);

/// `nominal` with errors as the hidden checks use: each position off by up
/// to `position` m per axis, yaw by up to `yaw` rad, each scale by up to
/// `scale`; sensor `mirror` (if >= 0) mirrored relative to nominal.
SensorArray perturbed(const SensorArray& nominal, std::mt19937_64& rng, double position, double yaw,
                      double scale, int mirror = -1);

/// Four sensors on a 0.1 m square, yaws 0.3, 1.9, -2.5, -0.7, cpi 800..1600.
SensorArray four_sensor_nominal();

/// Kim & Lee Section V: N = 3, r = 0.3, theta = -pi/6, 1600 cpi, aligned mice.
SensorArray kimlee_nominal();

}  // namespace moa::test
