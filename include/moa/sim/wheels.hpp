// Simulated wheel odometry: what the encoders of a three-omni-wheel or a
// differential-drive robot say the robot did, with slip, written as
// wheels.csv twists (log format v1); or an ideal reference twist.
//
// Wheel j sits at r_j (robot frame) and rolls along the unit vector d_j; its
// ground speed for a robot twist x is
//   g_j = d_j . (v + omega J r_j)                        (W x, one row per wheel)
// omni3: r_j = R (cos a_j, sin a_j), d_j = (-sin a_j, cos a_j):  g_j = -sin a_j vx + cos a_j vy + R
// omega differential: wheels at (0, +-b) rolling along x:  g = vx -+ b omega. mecanum: four
// wheels at (+-lx, +-ly) with 45-degree rollers, L = lx + ly: a wheel's rim speed is
//   front left vx - vy - L omega, front right vx + vy + L omega,
//   rear left  vx + vy - L omega, rear right vx - vy + L omega,
// and the odometry is their least-squares inverse. Slip: the wheel's
// surface turns faster than the ground moves under it when driving, and the encoder counts the
// surface:
//   m_j = g_j (1 + base_j + per_speed |g_j| + z_j) + per_accel dg_j/dt
// base_j differs per wheel (load, wear: a translation then reads as a slight
// turn), per_speed makes slip grow with speed, per_accel with acceleration
// (positive when speeding up, negative when braking), and z_j is random slip:
// an Ornstein-Uhlenbeck process of std. dev. `random` and correlation time
// `random_time`. The encoders count m_j in ticks of `encoder_resolution`
// metres (remainder carried), and a row's twist is the forward kinematics
// (W^-1, or its differential-drive form with vy = 0) of the wheel
// displacements over the row, divided by the row's duration, plus white
// noise of `noise_speed` (vx, vy) and `noise_rate` (omega). A slip burst adds `slip` to the
// slip fraction of one wheel (or all) for the frames whose midpoint lies in [start, end): a
// wheel spinning on a wet patch or a rug's edge.
// `reference`: the robot's true twist averaged over the row (the integral of
// the twist, i.e. the body-frame displacement per second), plus the same noise:
// the reference a calibration rig provides (Kim & Lee).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "moa/core/se2.hpp"
#include "moa/sim/random.hpp"

namespace moa::sim {

enum class DriveType { kNone, kOmni3, kDifferential, kMecanum, kReference };

/// The most wheels a drive has (mecanum).
inline constexpr int kMaxWheels = 4;

struct SlipBurst {
  double start = 0.0;  ///< s
  double end = 0.0;    ///< s
  double slip = 0.0;   ///< fraction added to the wheel's slip
  int wheel = -1;      ///< index, -1: every wheel
};

struct SlipModel {
  std::vector<double> base;  ///< per wheel, fraction of the ground speed
  double per_speed = 0.0;    ///< fraction per m/s of wheel speed
  double per_accel = 0.0;    ///< s (m/s of slip per m/s^2)
  double random = 0.0;       ///< std. dev. of the random slip fraction
  double random_time = 0.3;  ///< s, correlation time of the random slip
  std::vector<SlipBurst> bursts;
};

struct DriveModel {
  DriveType type = DriveType::kNone;
  double wheel_distance =
      0.0;  ///< m: R (omni3), half the track b (differential), lx + ly (mecanum)
  std::vector<double> wheel_angles;  ///< rad, omni3
  double rate = 100.0;               ///< wheels.csv rows per second
  SlipModel slip;
  double encoder_resolution = 0.0;  ///< m per tick; 0: no quantisation
  double noise_speed = 0.0;         ///< m/s, on vx and vy of each row
  double noise_rate = 0.0;          ///< rad/s, on omega of each row

  int wheel_count() const;
};

class WheelOdometry {
 public:
  WheelOdometry(const DriveModel& model, std::uint64_t seed);

  /// One frame of h seconds at constant true twist.
  void frame(const Twist2& twist, double h);
  /// The measured twist averaged over the frames since the previous row,
  /// `dt` seconds long; starts the next row.
  Twist2 take_row(double dt);

 private:
  DriveModel model_;
  Rng rng_;
  using Wheels = Eigen::Matrix<double, kMaxWheels, 1>;
  /// W: twist -> wheel ground speeds (rows past the wheel count are zero).
  Eigen::Matrix<double, kMaxWheels, 3> kinematics_ = Eigen::Matrix<double, kMaxWheels, 3>::Zero();
  /// Wheel displacements -> twist * dt (columns past the wheel count are zero).
  Eigen::Matrix<double, 3, kMaxWheels> forward_ = Eigen::Matrix<double, 3, kMaxWheels>::Zero();
  Wheels ground_prev_ = Wheels::Zero();
  Wheels random_slip_ = Wheels::Zero();
  Wheels travelled_ = Wheels::Zero();                    ///< m, real, per wheel
  Wheels counted_ = Wheels::Zero();                      ///< m in whole ticks, per wheel
  Wheels reported_ = Wheels::Zero();                     ///< counted_ at the previous row
  Eigen::Vector3d reference_ = Eigen::Vector3d::Zero();  ///< integral of the true twist
  double t_ = 0.0;                                       ///< s, the end of the last frame
};

}  // namespace moa::sim
