// A rigid array of N mouse sensors and one synchronised sample of it.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <span>

#include "moa/core/sensor.hpp"

namespace moa {

/// The largest array the fixed-size per-sample types hold. Sizes of every
/// per-sample matrix are bounded by it, so no per-sample call allocates.
inline constexpr int kMaxSensors = 16;

/// kMaxSensors copies of a zero Eigen vector or matrix (Eigen's default
/// constructor leaves them uninitialised, so `{}` is not enough).
template <class T>
std::array<T, kMaxSensors> zeros() {
  std::array<T, kMaxSensors> out;
  for (auto& x : out) x.setZero();
  return out;
}

/// Bit i set: sensor i takes part.
using SensorMask = std::uint32_t;
static_assert(kMaxSensors <= 32, "SensorMask must hold one bit per sensor");

inline SensorMask all_sensors(int n) {
  return n >= 32 ? ~SensorMask{0} : ((SensorMask{1} << n) - 1);
}
inline bool contains(SensorMask mask, int i) { return (mask >> i) & 1u; }
/// The number of bits set, counted in the lanes of the word (pairs, then
/// nibbles, then bytes summed by the multiplication into the top byte):
/// baseline x86-64 has no popcount instruction and std::popcount is a
/// library call there.
inline int count_sensors(SensorMask mask) {
  mask = mask - ((mask >> 1) & 0x55555555u);
  mask = (mask & 0x33333333u) + ((mask >> 2) & 0x33333333u);
  mask = (mask + (mask >> 4)) & 0x0F0F0F0Fu;
  return static_cast<int>((mask * 0x01010101u) >> 24);
}

/// Flags a sensor row may carry (log format v1, column `flags`).
enum SensorFlag : std::uint8_t {
  kFlagOverflow = 1u << 0,  ///< counter overflow seen in the interval
  kFlagLift = 1u << 1,      ///< sensor reported lift
};

/// The mounts of all sensors of one robot, in config order. Held in place
/// (no heap, so that the estimators run on microcontrollers without one):
/// at most kMaxSensors mounts, which every reader checks. An array given
/// more keeps the first kMaxSensors but reports its full size(), so that
/// every estimator refuses it (GeometryError::kTooManySensors).
class SensorArray {
 public:
  SensorArray() = default;
  explicit SensorArray(std::span<const SensorMount> mounts) { assign(mounts); }
  SensorArray(std::initializer_list<SensorMount> mounts) {
    assign(std::span<const SensorMount>(mounts.begin(), mounts.size()));
  }
  /// n copies of `mount`.
  SensorArray(int n, const SensorMount& mount) : n_(std::max(n, 0)) {
    std::fill_n(mounts_.begin(), std::min(n_, kMaxSensors), mount);
  }

  int size() const { return n_; }
  const SensorMount& operator[](int i) const { return mounts_[static_cast<std::size_t>(i)]; }
  SensorMount& operator[](int i) { return mounts_[static_cast<std::size_t>(i)]; }
  /// The sensors' rms distance from the robot's centre (m), sqrt(mean |p_i|^2).
  real rms_radius() const {
    real sum = 0;
    for (const auto& m : mounts()) sum += m.position.squaredNorm();
    return n_ > 0 ? std::sqrt(sum / static_cast<real>(n_)) : real(0);
  }
  std::span<const SensorMount> mounts() const {
    return std::span<const SensorMount>(mounts_).first(
        static_cast<std::size_t>(std::min(n_, kMaxSensors)));
  }

 private:
  void assign(std::span<const SensorMount> mounts) {
    n_ = static_cast<int>(mounts.size());
    std::copy_n(mounts.begin(), std::min(mounts.size(), mounts_.size()), mounts_.begin());
  }

  int n_ = 0;
  std::array<SensorMount, kMaxSensors> mounts_{};
};

/// Kim & Lee eq. (1): N mice at the vertices of a regular polygon of radius
/// r (m) centred on the robot, the first at angle theta (rad), each aligned
/// with the robot axes (yaw 0), other fields copied from `prototype`:
///   p_i = r (cos(theta + (i-1) 2 pi/N), sin(theta + (i-1) 2 pi/N)).
SensorArray regular_polygon(int n, real r, real theta, const SensorMount& prototype = {});

/// All sensors' counts over one common interval (t - dt, t].
struct ArraySample {
  double t = 0.0;  ///< s, end of the interval
  real dt = 0.0;   ///< s, interval length
  int size = 0;    ///< number of sensors
  /// Counts in each sensor's own frame accumulated over the interval. Real
  /// valued: a row spread over several intervals contributes a fraction.
  std::array<Vec2, kMaxSensors> counts = zeros<Vec2>();
  /// Lowest SQUAL reported in the interval (255 when none was reported).
  std::array<std::uint8_t, kMaxSensors> squal{};
  /// OR of the SensorFlag bits reported in the interval.
  std::array<std::uint8_t, kMaxSensors> flags{};
  /// OR of the simulator's fault bits (faults.csv) in the interval: only the
  /// oracle estimator reads them; zero for real data.
  std::array<std::uint8_t, kMaxSensors> faults{};
};

}  // namespace moa
