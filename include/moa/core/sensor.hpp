// One optical mouse sensor: where it sits, how it is turned, how it counts.
//
// The measurement model of docs/formats/config.md, used by every part of moa. For a
// robot twist (v, omega) in the robot frame and J = [[0,-1],[1,0]]:
//   u_i = v + omega J p_i                 velocity of the sensor point (robot frame)
//   w_i = R(yaw_i)^T u_i                  the same in the sensor frame
//   w_i.y = -w_i.y   if mirrored_i        (sensor y axis clockwise from x)
//   counts_i = k_i diag(scale_i) w_i dt,  k_i = cpi_i / 0.0254  counts per metre
// Written as one linear map, counts_i / dt = G_i u_i = G_i A_i (v, omega) with
//   G_i = k_i diag(scale_i) F_i R(yaw_i)^T,  F_i = diag(1, mirrored ? -1 : 1),
//   A_i = [I | J p_i]  (Kim & Lee eq. (6), Sekimori & Miyazaki eq. (3) rows).
#pragma once

#include <Eigen/Core>
#include <optional>

#include "moa/core/se2.hpp"
#include "moa/core/speed_scale.hpp"

namespace moa {

inline constexpr real kMetresPerInch = 0.0254;

struct SensorMount {
  Vec2 position{0.0, 0.0};        ///< m, sensor centre in the robot frame
  real yaw = 0.0;                 ///< rad, sensor x axis in the robot frame
  real cpi = 800.0;               ///< nominal counts per inch
  Vec2 scale{1.0, 1.0};           ///< per-axis correction of cpi
  bool mirrored = false;          ///< sensor y axis clockwise from x
  std::optional<real> max_speed;  ///< m/s, rated tracking speed
  std::optional<real> noise;      ///< m/s, std. dev. of each velocity axis
  /// s, a row's t minus the true end of its interval (USB polling, the
  /// firmware's K-frame accumulation); the synchroniser shifts the rows back.
  real latency = 0.0;
  /// Counted over true displacement as a function of the sensor point's
  /// ground speed (core/speed_scale.hpp); the identity unless configured.
  /// The pipeline divides each epoch's counts by it (corrected_counts).
  SpeedScale speed_scale;

  /// k = cpi / 0.0254: counts per metre before the per-axis scale.
  real counts_per_metre() const { return cpi / kMetresPerInch; }

  /// G_i: maps the sensor point's robot-frame velocity (m/s) to counts/s.
  Mat2 counts_from_robot_velocity() const;
  /// G_i^-1: maps counts/s to the sensor point's robot-frame velocity (m/s).
  Mat2 robot_velocity_from_counts() const;

  /// A_i = [I | J p_i] (2x3): robot twist to the sensor point's velocity,
  /// robot frame. Kim & Lee eq. (6), two rows per mouse.
  Mat<2, 3> point_jacobian() const;

  /// H_i = G_i A_i (2x3): d(counts_i / dt) / d(vx, vy, omega).
  Mat<2, 3> twist_jacobian() const { return counts_from_robot_velocity() * point_jacobian(); }

  /// Counts (real valued, before quantisation) for a constant twist over dt.
  Vec2 counts(const Twist2& twist, real dt) const { return twist_jacobian() * twist.vector() * dt; }

  /// d(counts_i / dt) / d(px, py, yaw, scale_x, scale_y) at a given twist (2x5):
  /// the Jacobian with respect to the mounting parameters, as a calibration
  /// needs it.
  Mat<2, 5> parameter_jacobian(const Twist2& twist) const;
};

/// The counts of one interval of dt (s) with the speed scale undone: the
/// counted displacement d = G^-1 counts has the counted speed c = |d| / dt;
/// the true speed s solves s ratio(s) = c, and the counts are divided by
/// ratio(s). The counts unchanged for the identity or dt <= 0.
Vec2 corrected_counts(const SpeedScale& scale, const Mat2& velocity_from_counts,
                      const Vec2& counts, real dt);

/// A sensor's rated figures (from the manufacturers' datasheets).
/// Counts implying a sensor-point speed above impossible_speed(mount) are a
/// corrupt value, refused (kImpossibleCounts): ten times the rated max_speed,
/// or 50 m/s for an unrated sensor (optical mouse sensors track at most a few
/// m/s). `moa odometry` and the calibrations refuse the same rows.
inline constexpr real kImpossibleSpeedFactor = 10.0;
inline constexpr real kImpossibleUnratedSpeed = 50.0;  ///< m/s
real impossible_speed(const SensorMount& mount);       ///< m/s
/// |velocity_from_counts * counts| > limit * dt: the counts over dt (s)
/// imply a speed above `limit` (m/s, > 0). Decided without the square root
/// where |.|^2 is clear of (limit dt)^2 by far more than the rounding of
/// either: the same answer as the norm's.
bool counts_impossible(const Mat2& velocity_from_counts, const Vec2& counts, real limit, real dt);

struct SensorPreset {
  const char* name;
  real cpi;         ///< counts per inch (the default setting)
  real max_speed;   ///< m/s
  real frame_rate;  ///< frames (packets) per second
};

/// Agilent HDNS-2051 (Sekimori & Miyazaki): 800 cpi, 14 in/s = 0.3556 m/s
/// (the decimal: 14 * 0.0254 rounds to 0.35559999999999997), 2300 Hz.
inline constexpr SensorPreset kHdns2051{"HDNS-2051", 800.0, 0.3556, 2300.0};
/// Avago ADNS-3080 (Kim & Lee Table I) at their setting: 1600 cpi (400 also
/// selectable), 40 in/s at 6400 fps (the sensor allows up to 6469 fps).
inline constexpr SensorPreset kAdns3080{"ADNS-3080", 1600.0, 40.0 * kMetresPerInch, 6400.0};
inline constexpr real kAdns3080LowCpi = 400.0;
inline constexpr real kAdns3080MaxFrameRate = 6469.0;

/// Kim & Lee eq. (50): the velocity (m/s) along one sensor axis from the sum
/// of K packets' counts, each packet one frame of 1/fps s:
///   v = (sum CNT_j / CPI) / (K / FPS)  in/s,  times 0.0254 for m/s.
inline real velocity_from_counts(real count_sum, real cpi, int packets, real fps) {
  return count_sum / cpi / (static_cast<real>(packets) / fps) * kMetresPerInch;
}

/// The acquisition microcontroller of Kim & Lee Section V: accumulates the
/// counts of every packet and emits their sum once every K packets.
class Downsampler {
 public:
  explicit Downsampler(int packets_per_output) : k_(packets_per_output) {}

  /// Adds one packet; returns the accumulated (dx, dy) on every K-th packet.
  std::optional<Eigen::Vector2i> push(int dx, int dy) {
    sum_ += Eigen::Vector2i(dx, dy);
    if (++count_ < k_) return std::nullopt;
    const Eigen::Vector2i out = sum_;
    sum_.setZero();
    count_ = 0;
    return out;
  }
  int packets_per_output() const { return k_; }

 private:
  int k_;
  int count_ = 0;
  Eigen::Vector2i sum_{0, 0};
};

}  // namespace moa
