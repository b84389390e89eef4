#include "moa/sim/random_world.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "moa/sim/random.hpp"

namespace moa::sim {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kMetresPerInch = 0.0254;

// The draws of one world, from their own stream of the seed.
class Draw {
 public:
  explicit Draw(std::uint64_t seed) : rng_(seed, Stream::kWorld) {}
  double uniform(double lo, double hi) { return rng_.uniform(lo, hi); }
  double log_uniform(double lo, double hi) {
    return std::exp(rng_.uniform(std::log(lo), std::log(hi)));
  }
  bool chance(double p) { return rng_.uniform() < p; }
  double sign() { return chance(0.5) ? 1.0 : -1.0; }
  /// lo..hi inclusive.
  int integer(int lo, int hi) {
    return lo + std::min(hi - lo, static_cast<int>(rng_.uniform() * (hi - lo + 1)));
  }
  /// An index drawn with the given weights.
  std::size_t pick(std::initializer_list<double> weights) {
    double total = 0.0;
    for (const double w : weights) total += w;
    double u = rng_.uniform() * total;
    std::size_t i = 0;
    for (const double w : weights) {
      if (u < w) return i;
      u -= w;
      ++i;
    }
    return weights.size() - 1;
  }
  double normal() { return rng_.normal(); }

 private:
  Rng rng_;
};

enum class Family { kClean, kFaults, kGyro, kFloor, kCalibration };
constexpr std::array<std::string_view, 5> kFamilyNames{"clean", "faults", "gyro", "floor",
                                                       "calibration"};

struct Segment {
  double vx = 0.0, vy = 0.0, omega = 0.0, duration = 0.0;
};

struct Sensor {
  double x = 0.0, y = 0.0, yaw = 0.0;
  bool mirrored = false;
};

// A number as YAML reads it back: shortest round trip.
std::string num(double x) { return fmt::format("{}", x); }

class Builder {
 public:
  Builder(std::uint64_t seed, Family family) : d_(seed), family_(family) {}

  RandomWorld build(std::uint64_t seed) {
    draw_robot();
    draw_sensor_model();
    draw_sensors();
    draw_gyro();
    draw_path();
    draw_wheels();
    draw_reference();
    draw_faults();
    draw_gyro_timing();
    judge_observability();
    RandomWorld w;
    w.family = std::string(kFamilyNames[static_cast<std::size_t>(family_)]);
    w.summary = summary();
    w.yaml = yaml(seed, w.family, w.summary);
    w.scenario = parse_scenario(w.yaml, fmt::format("random world {} ({})", seed, w.family));
    return w;
  }

 private:
  // ------------------------------------------------------------- the draws
  void draw_robot() {
    drive_ =
        std::array<const char*, 3>{"omni3", "differential", "mecanum"}[d_.pick({0.4, 0.3, 0.3})];
    robot_radius_ = d_.uniform(0.08, 0.25);
  }

  void draw_sensor_model() {
    cpi_ = std::round(d_.log_uniform(400.0, 12000.0) / 50.0) * 50.0;
    rated_speed_ = d_.log_uniform(0.4, 6.0);
    frame_rate_ = std::round(d_.uniform(1000.0, 12000.0));
    // K frames per row: the row rate frame_rate / K within [100, 2000].
    const double row_rate = d_.log_uniform(100.0, 2000.0);
    const int fewest = static_cast<int>(std::ceil(frame_rate_ / 2000.0));
    const int most = static_cast<int>(std::floor(frame_rate_ / 100.0));
    packets_ = std::clamp(static_cast<int>(std::round(frame_rate_ / row_rate)), fewest, most);
    frame_noise_ = d_.uniform(0.0, 0.1);
    relative_noise_ = d_.uniform(0.0, 0.02);
    squal_ = d_.uniform(40.0, 150.0);
    squal_jitter_ = d_.uniform(0.0, 8.0);
    // An 8-bit delta register on low-resolution parts, 16 bits above.
    delta_limit_ = cpi_ <= 1600.0 ? 127 : 32767;
  }
  double row_period() const { return packets_ / frame_rate_; }

  void draw_sensors() {
    const std::size_t n_index = d_.pick({0.1, 0.2, 0.25, 0.25, 0.1, 0.1});
    n_ = static_cast<int>(n_index) + 1;
    across_ = d_.uniform(0.01, 0.15);
    const double offset = d_.uniform(0.0, 0.05), heading = d_.uniform(-kPi, kPi);
    const double cx = offset * std::cos(heading), cy = offset * std::sin(heading);
    const double r = across_ / 2.0;
    // Uniform in the disc, at least across / (2 n) apart (not coincident).
    for (int attempt = 0; attempt < 200; ++attempt) {
      sensors_.clear();
      for (int i = 0; i < n_; ++i) {
        const double rho = r * std::sqrt(d_.uniform(0.0, 1.0)), a = d_.uniform(-kPi, kPi);
        sensors_.push_back({cx + rho * std::cos(a), cy + rho * std::sin(a), 0.0, false});
      }
      double closest = 1e9;
      for (int i = 0; i < n_; ++i) {
        for (int j = i + 1; j < n_; ++j) {
          closest = std::min(
              closest, std::hypot(sensors_[i].x - sensors_[j].x, sensors_[i].y - sensors_[j].y));
        }
      }
      if (closest >= across_ / (2.0 * n_)) break;
    }
    for (auto& s : sensors_) {
      s.yaw = d_.uniform(-kPi, kPi);
      s.mirrored = d_.chance(0.15);
    }
    reach_ = 0.0;
    for (const auto& s : sensors_) reach_ = std::max(reach_, std::hypot(s.x, s.y));
    // Build errors: a calibrated robot, or (family calibration) one as
    // assembled: up to 8 mm, 4 degrees and 4 % off.
    const bool large = family_ == Family::kCalibration;
    const double sp = large ? d_.uniform(0.002, 0.008) : d_.uniform(0.0, 0.0003);
    const double sy = large ? d_.uniform(0.01, 0.07) : d_.uniform(0.0, 0.005);
    const double ss = large ? d_.uniform(0.01, 0.04) : d_.uniform(0.0, 0.003);
    for (int i = 0; i < n_; ++i) {
      Build b;
      b.dx = large ? d_.uniform(-sp, sp) : sp * d_.normal();
      b.dy = large ? d_.uniform(-sp, sp) : sp * d_.normal();
      b.dyaw = large ? d_.uniform(-sy, sy) : sy * d_.normal();
      b.sx = 1.0 + (large ? d_.uniform(-ss, ss) : ss * d_.normal());
      b.sy = 1.0 + (large ? d_.uniform(-ss, ss) : ss * d_.normal());
      if (d_.chance(0.5)) {
        b.latency = d_.uniform(0.0, 0.01);
        b.jitter = d_.uniform(0.0, 0.3) * row_period();
      }
      build_.push_back(b);
    }
  }

  void draw_gyro() {
    // One sensor sees no rotation: it needs a gyro.
    gyro_ = n_ == 1 || family_ == Family::kGyro || d_.chance(0.6);
    if (!gyro_) return;
    g_rate_ = std::array<double, 4>{100.0, 200.0, 400.0, 1000.0}[d_.pick({1, 1, 1, 1})];
    g_scale_ = 1.0 + d_.uniform(-0.03, 0.03);
    g_bias_ = d_.uniform(-0.05, 0.05);
    g_walk_ = d_.chance(0.5) ? d_.uniform(0.0, 1e-4) : 0.0;
    g_noise_ = d_.log_uniform(5e-5, 5e-4);
    g_max_ = d_.log_uniform(250.0, 2000.0) * kPi / 180.0;
    g_latency_ = d_.chance(0.6) ? d_.uniform(0.0, 0.01) : 0.0;
  }

  // Drawn after everything else, so the worlds drawn before it existed are
  // the same but for it.
  void draw_gyro_timing() {
    // A robot program's stamps are off by milliseconds: the latency the
    // config states is wrong, in the families that test the gyro and the
    // calibration.
    if (!gyro_ || (family_ != Family::kGyro && family_ != Family::kCalibration)) return;
    if (d_.chance(0.5)) g_latency_error_ = d_.uniform(-0.01, 0.01);
  }

  void draw_path() {
    v_max_ = d_.uniform(0.2, 1.5);
    w_max_ = d_.uniform(0.5, 8.0);
    if (family_ == Family::kClean || family_ == Family::kCalibration) {
      // Every sensor point under 0.8 of its rating, the gyro under its full scale.
      const double room = 0.8 * rated_speed_;
      v_max_ = std::min(v_max_, 0.6 * room);
      w_max_ = std::min(w_max_, 0.4 * room / std::max(reach_, 1e-3));
      if (gyro_) w_max_ = std::min(w_max_, 0.8 * (g_max_ - std::abs(g_bias_)) / g_scale_);
    }
    accel_ = d_.uniform(0.5, 3.0);
    angular_accel_ = d_.uniform(3.0, 30.0);
    const double target = d_.uniform(15.0, 50.0);
    if (d_.chance(0.6)) segments_.push_back({0, 0, 0, d_.log_uniform(0.2, 10.0)});
    const bool sideways = std::string_view(drive_) != "differential";
    while (total() < target) {
      Segment s;
      const std::size_t kind = d_.pick({0.15, 0.3, 0.25, 0.2, 0.1});
      switch (kind) {
        case 0:  // rest
          s.duration = d_.log_uniform(0.2, 10.0);
          break;
        case 1:    // cruise
        case 2: {  // arc: a cruise that turns as well
          const double speed = d_.uniform(0.3, 1.0) * v_max_;
          const double a = sideways ? d_.uniform(-kPi, kPi) : (d_.chance(0.8) ? 0.0 : kPi);
          s.vx = speed * std::cos(a);
          s.vy = sideways ? speed * std::sin(a) : 0.0;
          s.duration = d_.uniform(0.5, 6.0);
          if (s.vy == 0.0 && s.vx == 0.0) s.vx = speed;
          break;
        }
        case 3:  // a turn in place, either way
          s.omega = d_.sign() * d_.uniform(0.2, 1.0) * w_max_;
          s.duration =
              std::min(d_.uniform(0.3, 4.0), d_.uniform(0.5, 2.0) * 2.0 * kPi / std::abs(s.omega));
          break;
        default:  // a spin: several turns fast
          s.omega = d_.sign() * d_.uniform(0.7, 1.0) * w_max_;
          s.duration = d_.uniform(1.0, 4.0);
          break;
      }
      if (kind == 2) s.omega = d_.sign() * d_.uniform(0.1, 0.6) * w_max_;
      segments_.push_back(s);
    }
    segments_.push_back({0, 0, 0, d_.uniform(0.5, 2.0)});
    duration_ = total();
  }
  double total() const {
    double t = 0.0;
    for (const auto& s : segments_) t += s.duration;
    return t;
  }

  void draw_wheels() {
    const std::size_t kind =
        family_ == Family::kCalibration ? d_.pick({0.0, 0.5, 0.5}) : d_.pick({0.25, 0.25, 0.5});
    wheels_ = std::array<const char*, 3>{"none", "exact", "noisy"}[kind];
    if (kind == 0) return;
    wheel_distance_ = std::string_view(drive_) == "mecanum" ? d_.uniform(0.1, 0.4) : robot_radius_;
    encoder_ = d_.log_uniform(1e-5, 1e-4);
    const int count = std::string_view(drive_) == "omni3"     ? 3
                      : std::string_view(drive_) == "mecanum" ? 4
                                                              : 2;
    for (int j = 0; j < count; ++j) slip_base_.push_back(d_.uniform(0.0, 0.1));
    slip_speed_ = d_.uniform(0.0, 0.1);
    slip_random_ = d_.uniform(0.0, 0.05);
    if (kind == 2) {
      wheel_noise_speed_ = d_.uniform(0.002, 0.03);
      wheel_noise_rate_ = d_.uniform(0.005, 0.1);
    }
    wheel_count_ = count;
  }

  void draw_reference() {
    const std::size_t kind = d_.pick({0.5, 0.25, 0.25});
    camera_ = std::array<const char*, 3>{"none", "mocap", "camera"}[kind];
    if (kind == 1) {
      c_rate_ = d_.uniform(60.0, 240.0);
      c_noise_ = d_.uniform(1e-4, 1e-3);
      c_heading_ = d_.uniform(0.05, 0.3) * kPi / 180.0;
      c_latency_ = d_.uniform(0.0, 0.02);
    } else if (kind == 2) {
      c_rate_ = d_.uniform(5.0, 30.0);
      c_noise_ = d_.uniform(0.001, 0.01);
      c_latency_ = d_.uniform(0.02, 0.15);
      c_jitter_ = d_.uniform(0.0, 0.01);
      c_drop_ = d_.uniform(0.0, 0.1);
    }
  }

  // A window inside the run, away from its first and last tenth.
  std::pair<double, double> window(double lo, double hi) {
    const double length = d_.uniform(lo, hi);
    const double start =
        d_.uniform(0.1 * duration_, std::max(0.1 * duration_, 0.9 * duration_ - length));
    return {start, std::min(start + length, duration_ - 0.01)};
  }
  std::string name(int i) const { return fmt::format("m{}", i + 1); }

  void add_event(const std::string& line, const std::string& text) {
    events_.push_back(line);
    faults_text_.push_back(text);
  }

  void sensor_fault(int kind) {
    const int i = d_.integer(0, n_ - 1);
    const std::string m = name(i);
    switch (kind) {
      case 0: {  // frozen register
        const auto [a, b] = window(0.2, 4.0);
        add_event(fmt::format("{{type: stuck, sensor: {}, start: {}, end: {}}}", m, num(a), num(b)),
                  fmt::format("{} frozen {:.1f}-{:.1f} s", m, a, b));
        if (n_ == 1) lone_sensor_fault_ = true;
        break;
      }
      case 1: {  // reads zero, no warning
        const auto [a, b] = window(0.2, 3.0);
        add_event(fmt::format("{{type: liftoff, sensor: {}, start: {}, end: {}, squal: {}, "
                              "lift_flag: false}}",
                              m, num(a), num(b), static_cast<int>(squal_)),
                  fmt::format("{} zero {:.1f}-{:.1f} s", m, a, b));
        if (n_ == 1) lone_sensor_fault_ = true;
        break;
      }
      case 2:  // intermittent lift
        intermittent_lift(i);
        break;
      case 3: {  // spikes
        const auto [a, b] = window(1.0, 10.0);
        const double magnitude = d_.uniform(0.002, 0.02) * cpi_ / kMetresPerInch;
        const double rate = d_.uniform(1.0, 20.0);
        add_event(fmt::format("{{type: spikes, sensor: {}, start: {}, end: {}, rate: {}, "
                              "magnitude: {}}}",
                              m, num(a), num(b), num(rate), num(magnitude)),
                  fmt::format("{} spikes {:.1f}-{:.1f} s ({:.0f}/s)", m, a, b, rate));
        break;
      }
      case 4: {  // drift (dust)
        if (n_ == 1) lone_sensor_fault_ = true;
        const double a = d_.uniform(0.1, 0.6) * duration_;
        const double ramp = d_.uniform(2.0, 20.0), scale = 1.0 + d_.sign() * d_.uniform(0.03, 0.15);
        add_event(
            fmt::format("{{type: drift, sensor: {}, start: {}, end: {}, scale: {}, ramp: {}}}", m,
                        num(a), num(duration_), num(scale), num(ramp)),
            fmt::format("{} drifting to {:+.1f} % from {:.1f} s", m, 100 * (scale - 1), a));
        break;
      }
      case 5: {  // dirty
        if (n_ == 1) lone_sensor_fault_ = true;
        const auto [a, b] = window(0.5, 5.0);
        const double retained = d_.uniform(0.2, 0.8);
        add_event(fmt::format("{{type: dirty, sensor: {}, start: {}, end: {}, retained: {}, squal: "
                              "{}}}",
                              m, num(a), num(b), num(retained), d_.integer(5, 30)),
                  fmt::format("{} dirty {:.1f}-{:.1f} s", m, a, b));
        break;
      }
      default:  // a floor step on one sensor
        floor_step({i});
        break;
    }
  }

  void intermittent_lift(int i) {
    const auto [a, b] = window(5.0, 20.0);
    const bool flag = d_.chance(0.5);
    const int squal = flag ? d_.integer(1, 20) : static_cast<int>(squal_);
    int lifts = 0;
    for (double t = a + d_.uniform(0.0, 1.0); t < b; t += d_.uniform(1.0, 3.0)) {
      const double end = std::min(t + d_.uniform(0.05, 0.3), duration_ - 0.01);
      if (end <= t) break;
      events_.push_back(
          fmt::format("{{type: liftoff, sensor: {}, start: {}, end: {}, squal: {}, lift_flag: {}}}",
                      name(i), num(t), num(end), squal, flag ? "true" : "false"));
      ++lifts;
    }
    faults_text_.push_back(fmt::format("{} lifting {} times {:.1f}-{:.1f} s{}", name(i), lifts, a,
                                       b, flag ? "" : " (no lift flag)"));
    if (n_ == 1) lone_sensor_fault_ = true;
  }

  // Each listed sensor reads 0-9 % short from one moment on (a new floor).
  void floor_step(const std::vector<int>& which) {
    if (n_ == 1) lone_sensor_fault_ = true;
    const double t = d_.uniform(0.2, 0.8) * duration_;
    const bool same = which.size() > 1 && d_.chance(0.3);
    const double common = d_.uniform(0.91, 1.0);
    for (const int i : which) {
      const double scale = same ? common : d_.uniform(0.91, 1.0);
      events_.push_back(fmt::format("{{type: drift, sensor: {}, start: {}, end: {}, scale: {}}}",
                                    name(i), num(t), num(duration_), num(scale)));
    }
    if (static_cast<int>(which.size()) == n_) {
      floor_all_ = true;
      floor_time_ = t;
      faults_text_.push_back(
          fmt::format("floor change under {} at {:.1f} s{}",
                      n_ == 1 ? std::string("the sensor") : fmt::format("all {} sensors", n_), t,
                      same ? " (the same amount)" : ""));
    } else {
      std::vector<std::string> names;
      for (const int i : which) names.push_back(name(i));
      faults_text_.push_back(
          fmt::format("floor change under {} at {:.1f} s", fmt::join(names, ","), t));
    }
  }

  void common_dropout() {
    const auto [a, b] = window(0.1, 0.5);
    for (int i = 0; i < n_; ++i) {
      events_.push_back(fmt::format(
          "{{type: liftoff, sensor: {}, start: {}, end: {}, squal: {}, lift_flag: false}}", name(i),
          num(a), num(b), static_cast<int>(squal_)));
    }
    faults_text_.push_back(fmt::format("all sensors zero {:.2f}-{:.2f} s", a, b));
    dropouts_.push_back(a);
  }

  void gyro_fault() {
    if (d_.chance(0.5)) {
      const auto [a, b] = window(0.2, 3.0);
      gyro_faults_.push_back(fmt::format("{{type: stuck, start: {}, end: {}}}", num(a), num(b)));
      faults_text_.push_back(fmt::format("gyro stuck {:.1f}-{:.1f} s", a, b));
    } else {
      const double a = d_.uniform(0.2, 0.7) * duration_;
      const double step = d_.sign() * d_.uniform(0.005, 0.03);
      gyro_faults_.push_back(
          fmt::format("{{type: bias_step, start: {}, step: {}}}", num(a), num(step)));
      faults_text_.push_back(fmt::format("gyro bias step {:+.3f} rad/s at {:.1f} s", step, a));
    }
  }

  void slip_burst() {
    const auto [a, b] = window(0.3, 3.0);
    const double slip = d_.uniform(0.2, 1.0);
    const int wheel = d_.chance(0.6) ? d_.integer(0, wheel_count_ - 1) : -1;
    bursts_.push_back(
        wheel < 0 ? fmt::format("{{start: {}, end: {}, slip: {}}}", num(a), num(b), num(slip))
                  : fmt::format("{{start: {}, end: {}, slip: {}, wheel: {}}}", num(a), num(b),
                                num(slip), wheel));
    faults_text_.push_back(
        fmt::format("{} slipping {:+.0f} % {:.1f}-{:.1f} s",
                    wheel < 0 ? std::string("all wheels") : fmt::format("wheels[{}]", wheel),
                    100 * slip, a, b));
  }

  void draw_faults() {
    switch (family_) {
      case Family::kClean:
      case Family::kCalibration:
        return;
      case Family::kFaults: {
        const int count = d_.integer(1, 4);
        for (int k = 0; k < count; ++k) {
          // Sensor classes, common-mode dropout, the gyro's, the wheels'.
          const std::size_t c =
              d_.pick({6.0, 1.0, gyro_ ? 1.0 : 0.0, wheel_count_ > 0 ? 1.0 : 0.0});
          if (c == 0) sensor_fault(d_.integer(0, 6));
          if (c == 1) common_dropout();
          if (c == 2) gyro_fault();
          if (c == 3) slip_burst();
        }
        return;
      }
      case Family::kGyro:
        if (d_.chance(0.6)) gyro_fault();
        if (d_.chance(0.3)) gyro_fault();
        if (d_.chance(0.3)) common_dropout();
        return;
      case Family::kFloor: {
        std::vector<int> which;
        if (d_.chance(0.5)) {
          for (int i = 0; i < n_; ++i) which.push_back(i);
        } else {
          for (int i = 0; i < n_; ++i) {
            if (d_.chance(0.5)) which.push_back(i);
          }
          if (which.empty()) which.push_back(d_.integer(0, n_ - 1));
        }
        floor_step(which);
        if (d_.chance(0.6)) intermittent_lift(d_.integer(0, n_ - 1));
        return;
      }
    }
  }

  void judge_observability() {
    const bool wheels = std::string_view(wheels_) != "none";
    const bool camera = std::string_view(camera_) != "none";
    if (floor_all_ && !wheels && !camera) {
      unobservable_.push_back(fmt::format(
          "the scale change common to every sensor at {:.1f} s (no wheels, no camera beside them)",
          floor_time_));
    }
    for (const double t : dropouts_) {
      if (!wheels) {
        unobservable_.push_back(
            fmt::format("the {} while every sensor reads zero from {:.2f} s (no wheels{})",
                        gyro_ ? "translation" : "motion", t, gyro_ ? "" : ", no gyro"));
      }
    }
    if (lone_sensor_fault_ && !wheels) {
      unobservable_.push_back("the translation while the only sensor is faulty (no wheels)");
    }
  }

  // ------------------------------------------------------------- the text
  std::string summary() const {
    double spread = 0.0;  // the sensors' largest distance apart
    for (const auto& a : sensors_) {
      for (const auto& b : sensors_) spread = std::max(spread, std::hypot(a.x - b.x, a.y - b.y));
    }
    const std::string array =
        n_ == 1 ? fmt::format("1 sensor {:.1f} cm from the centre",
                              100 * std::hypot(sensors_[0].x, sensors_[0].y))
                : fmt::format("{} sensors {:.1f} cm apart at most", n_, 100 * spread);
    std::string s = fmt::format(
        "{}, {}, {:.0f} cpi rated {:.2f} m/s, {:.0f} rows/s; "
        "path {:.0f} s up to {:.2f} m/s and {:.1f} rad/s; wheels {}",
        drive_, array, cpi_, rated_speed_, frame_rate_ / packets_, duration_, v_max_, w_max_,
        wheels_);
    if (gyro_) {
      s += fmt::format("; gyro scale {:+.1f} %, bias {:+.3f} rad/s, full scale {:.0f} deg/s",
                       100 * (g_scale_ - 1), g_bias_, g_max_ * 180 / kPi);
      if (g_latency_error_ != 0.0) {
        s += fmt::format(", stamps {:+.1f} ms later than the config says", 1e3 * g_latency_error_);
      }
    } else {
      s += "; no gyro";
    }
    if (std::string_view(camera_) != "none") s += fmt::format("; {} {:.0f} Hz", camera_, c_rate_);
    s += "; faults: ";
    if (faults_text_.empty()) s += "none";
    s += fmt::format("{}", fmt::join(faults_text_, ", "));
    return s;
  }

  std::string yaml(std::uint64_t seed, const std::string& family, const std::string& line) const {
    std::string y;
    auto out = std::back_inserter(y);
    fmt::format_to(out, "# moa simulate --random {} --family {}\n", seed, family);
    fmt::format_to(out, "version: 1\nname: random-{}-{}\n", family, seed);
    std::string quoted;
    for (const char c : line) quoted += c == '"' ? std::string("\\\"") : std::string(1, c);
    fmt::format_to(out, "description: \"{}\"\n", quoted);
    fmt::format_to(out,
                   "sensor_model:\n  preset: ADNS-3080\n  cpi: {}\n  max_speed: {}\n"
                   "  frame_rate: {}\n  packets_per_row: {}\n  frame_noise: {}\n"
                   "  relative_noise: {}\n  delta_limit: {}\n  squal: {}\n  squal_jitter: {}\n",
                   num(cpi_), num(rated_speed_), num(frame_rate_), packets_, num(frame_noise_),
                   num(relative_noise_), delta_limit_, num(squal_), num(squal_jitter_));
    y += "sensors:\n";
    for (int i = 0; i < n_; ++i) {
      const Sensor& s = sensors_[static_cast<std::size_t>(i)];
      fmt::format_to(out, "  - {{name: {}, position: [{}, {}], yaw: {}, mirrored: {}}}\n", name(i),
                     num(s.x), num(s.y), num(s.yaw), s.mirrored ? "true" : "false");
    }
    y += "true_sensors:\n";
    for (int i = 0; i < n_; ++i) {
      const Build& b = build_[static_cast<std::size_t>(i)];
      fmt::format_to(
          out,
          "  {}: {{position_error: [{}, {}], yaw_error: {}, scale: [{}, {}], latency: {}, "
          "jitter: {}}}\n",
          name(i), num(b.dx), num(b.dy), num(b.dyaw), num(b.sx), num(b.sy), num(b.latency),
          num(b.jitter));
    }
    if (std::string_view(wheels_) != "none") {
      fmt::format_to(out,
                     "drive:\n  type: {}\n  wheel_distance: {}\n  rate: 100\n"
                     "  encoder_resolution: {}\n",
                     drive_, num(wheel_distance_), num(encoder_));
      if (std::string_view(drive_) == "omni3") y += "  wheel_angles_deg: [90, 210, 330]\n";
      y += "  slip:\n    base: [";
      std::vector<std::string> base;
      for (const double b : slip_base_) base.push_back(num(b));
      y += fmt::format("{}", fmt::join(base, ", "));
      fmt::format_to(out, "]\n    per_speed: {}\n    random: {}\n", num(slip_speed_),
                     num(slip_random_));
      if (!bursts_.empty()) {
        y += "    bursts:\n";
        for (const auto& b : bursts_) y += "      - " + b + "\n";
      }
      fmt::format_to(out, "  noise_speed: {}\n  noise_rate: {}\n", num(wheel_noise_speed_),
                     num(wheel_noise_rate_));
    }
    fmt::format_to(out,
                   "motion:\n  type: twists\n  max_accel: {}\n  max_angular_accel: {}\n"
                   "  segments:\n",
                   num(accel_), num(angular_accel_));
    for (const Segment& s : segments_) {
      fmt::format_to(out, "    - {{twist: [{}, {}, {}], duration: {}}}\n", num(s.vx), num(s.vy),
                     num(s.omega), num(s.duration));
    }
    y += "faults:\n  tracking_loss: {rate: 10, mean_duration: 0.1, retained: [0, 0.5]}\n";
    if (!events_.empty()) {
      y += "  events:\n";
      for (const auto& e : events_) y += "    - " + e + "\n";
    }
    if (std::string_view(camera_) == "mocap") {
      fmt::format_to(out,
                     "camera:\n  mode: mocap\n  rate: {}\n  noise: {}\n  heading_noise: {}\n"
                     "  latency: {}\n",
                     num(c_rate_), num(c_noise_), num(c_heading_), num(c_latency_));
    } else if (std::string_view(camera_) == "camera") {
      fmt::format_to(out,
                     "camera:\n  mode: positions\n  rate: {}\n  noise: {}\n  latency: {}\n"
                     "  jitter: {}\n  drop: {}\n",
                     num(c_rate_), num(c_noise_), num(c_latency_), num(c_jitter_), num(c_drop_));
    }
    if (gyro_) {
      fmt::format_to(out,
                     "imu:\n  rate: {}\n  scale: {}\n  bias: {}\n  bias_walk: {}\n"
                     "  noise_density: {}\n  max_rate: {}\n  latency: {}\n",
                     num(g_rate_), num(g_scale_), num(g_bias_), num(g_walk_), num(g_noise_),
                     num(g_max_), num(g_latency_));
      if (g_latency_error_ != 0.0)
        fmt::format_to(out, "  latency_error: {}\n", num(g_latency_error_));
      if (!gyro_faults_.empty()) {
        y += "  faults:\n";
        for (const auto& g : gyro_faults_) y += "    - " + g + "\n";
      }
    }
    if (!unobservable_.empty()) {
      y += "unobservable:\n";
      for (const auto& u : unobservable_) y += "  - \"" + u + "\"\n";
    }
    return y;
  }

  struct Build {
    double dx = 0.0, dy = 0.0, dyaw = 0.0, sx = 1.0, sy = 1.0, latency = 0.0, jitter = 0.0;
  };

  Draw d_;
  Family family_;
  const char* drive_ = "omni3";
  double robot_radius_ = 0.1;
  double cpi_ = 1600.0, rated_speed_ = 1.0, frame_rate_ = 6400.0;
  int packets_ = 64;
  double frame_noise_ = 0.0, relative_noise_ = 0.0, squal_ = 100.0, squal_jitter_ = 0.0;
  int delta_limit_ = 127;
  int n_ = 1;
  double across_ = 0.05, reach_ = 0.0;
  std::vector<Sensor> sensors_;
  std::vector<Build> build_;
  bool gyro_ = false;
  double g_rate_ = 100.0, g_scale_ = 1.0, g_bias_ = 0.0, g_walk_ = 0.0, g_noise_ = 1.5e-4,
         g_max_ = 8.7, g_latency_ = 0.0, g_latency_error_ = 0.0;
  double v_max_ = 0.5, w_max_ = 2.0, accel_ = 1.0, angular_accel_ = 10.0, duration_ = 0.0;
  std::vector<Segment> segments_;
  const char* wheels_ = "none";
  int wheel_count_ = 0;
  double wheel_distance_ = 0.1, encoder_ = 2e-5, slip_speed_ = 0.0, slip_random_ = 0.0,
         wheel_noise_speed_ = 0.0, wheel_noise_rate_ = 0.0;
  std::vector<double> slip_base_;
  const char* camera_ = "none";
  double c_rate_ = 10.0, c_noise_ = 0.005, c_heading_ = 0.0, c_latency_ = 0.0, c_jitter_ = 0.0,
         c_drop_ = 0.0;
  std::vector<std::string> events_, gyro_faults_, bursts_, faults_text_, unobservable_;
  bool floor_all_ = false, lone_sensor_fault_ = false;
  double floor_time_ = 0.0;
  std::vector<double> dropouts_;
};

}  // namespace

const std::vector<std::string>& random_families() {
  static const std::vector<std::string> names{"clean", "faults",      "gyro",
                                              "floor", "calibration", "any"};
  return names;
}

RandomWorld random_scenario(std::uint64_t seed, std::string_view family) {
  Family f = Family::kClean;
  if (family == "any") {
    // The family of an `any` seed is drawn from the seed alone.
    Rng rng(seed, Stream::kWorldFamily);
    f = static_cast<Family>(std::min<std::size_t>(4, static_cast<std::size_t>(rng.uniform() * 5)));
  } else {
    const auto it = std::find(kFamilyNames.begin(), kFamilyNames.end(), family);
    if (it == kFamilyNames.end()) {
      throw std::invalid_argument(fmt::format("unknown family '{}' (known: {})", family,
                                              fmt::join(random_families(), ", ")));
    }
    f = static_cast<Family>(it - kFamilyNames.begin());
  }
  return Builder(seed, f).build(seed);
}

}  // namespace moa::sim
