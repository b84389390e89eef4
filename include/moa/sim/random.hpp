// Deterministic random numbers for the simulator.
//
// The standard library's distributions are implementation defined (libstdc++
// and libc++ give different normals for the same engine), so "same seed, same
// bytes" needs its own: xoshiro256** (Blackman & Vigna) seeded through
// splitmix64, uniforms from the top 53 bits, normals by Box-Muller.
//
// Every noise source of a simulation draws from its own stream, derived from
// the run's seed and a stream id, so that switching on a fault for one sensor
// leaves every other sensor's noise, the wheels and the camera unchanged.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>

namespace moa::sim {

/// splitmix64 step: a 64-bit mixer (Steele, Lea & Flood 2014).
inline std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

/// Stream ids: one per noise source of a simulation.
enum class Stream : std::uint64_t {
  kSensorNoise = 1,  ///< + sensor index * kStreamStride
  kSensorFaults = 2,
  kSensorSqual = 3,
  kWheels = 4,
  kCamera = 5,
  kGyro = 6,
  kSensorClock = 7,  ///< + sensor index * kStreamStride: a row's jitter
  kWheelClock = 8,
  kCameraClock = 9,
  kCameraDrop = 10,
  kWorld = 11,        ///< a random world's draws (random_world.hpp)
  kWorldFamily = 12,  ///< the family of a seed of family `any`
};
inline constexpr std::uint64_t kStreamStride = 16;

class Rng {
 public:
  /// The generator of stream `stream` (+ `index` for per-sensor streams) of
  /// a run with `seed`.
  Rng(std::uint64_t seed, Stream stream, int index = 0) {
    std::uint64_t s =
        seed ^ (0x6a09e667f3bcc909ull * (static_cast<std::uint64_t>(stream) +
                                         kStreamStride * static_cast<std::uint64_t>(index)));
    s0_ = splitmix64(s);
    s1_ = splitmix64(s);
    s2_ = splitmix64(s);
    s3_ = splitmix64(s);
  }

  std::uint64_t next() {
    const std::uint64_t result = rotl(s1_ * 5, 7) * 9;
    const std::uint64_t t = s1_ << 17;
    s2_ ^= s0_;
    s3_ ^= s1_;
    s1_ ^= s2_;
    s0_ ^= s3_;
    s2_ ^= t;
    s3_ = rotl(s3_, 45);
    return result;
  }

  /// Uniform on [0, 1), 53 random bits.
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

  /// Standard normal (Box-Muller; the second value of each pair is kept).
  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = 1.0 - uniform();  // (0, 1]: log stays finite
    const double u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    const double a = 2.0 * std::numbers::pi * u2;
    spare_ = r * std::sin(a);
    has_spare_ = true;
    return r * std::cos(a);
  }

  /// Exponential with the given mean.
  double exponential(double mean) { return -mean * std::log(1.0 - uniform()); }

 private:
  static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

  // Four words rather than an array: this runs several times per simulated
  // frame, also in unoptimised test builds.
  std::uint64_t s0_ = 0, s1_ = 0, s2_ = 0, s3_ = 0;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace moa::sim
