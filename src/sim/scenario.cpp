#include "moa/sim/scenario.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/LU>
#include <algorithm>
#include <climits>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <numbers>
#include <optional>
#include <sstream>
#include <system_error>

#include "builtin_scenarios.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/csv.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/read_file.hpp"
#include "moa/formats/yaml.hpp"

namespace moa::sim {
namespace {

using Source = io::YamlSource;
using Fields = io::YamlFields;
using io::describe_kind;

// Physical bounds on a scenario's numbers (docs/simulator.md). Real sensors
// run at 1 500 to 12 000 frames/s and 400 to 25 600 cpi; the bounds are
// wide around that, and narrow enough that every count, frame number and
// rate ratio of the simulator fits the integer it is cast to.
constexpr double kMaxFrameRate = 1e6;    // frames/s
constexpr double kMaxCpi = 1e5;          // counts per inch
constexpr double kMaxSensorSpeed = 1e3;  // m/s, rated speed
constexpr double kMinRate = 1e-3;        // Hz: truth, wheel and camera rates
constexpr long kMaxPacketsPerRow = 100000;

// A duration (s) within (0, kMaxScenarioDuration].
double duration_of(const Fields& f, std::string_view key) {
  const double d = f.positive(key);
  if (d > kMaxScenarioDuration) {
    f.fail(key, fmt::format("must be at most {} s (found {})", kMaxScenarioDuration, d));
  }
  return d;
}

SensorModel parse_sensor_model(const Fields& f) {
  SensorModel m;
  const std::string preset = f.choice("preset", {kHdns2051.name, kAdns3080.name});
  const SensorPreset& p = preset == kHdns2051.name ? kHdns2051 : kAdns3080;
  m.preset = p.name;
  m.cpi = f.bounded("cpi", 1.0, kMaxCpi, p.cpi);
  m.max_speed = f.positive("max_speed", p.max_speed);
  if (m.max_speed > kMaxSensorSpeed) {
    f.fail("max_speed",
           fmt::format("must be within (0, {}] (found {})", kMaxSensorSpeed, m.max_speed));
  }
  m.frame_rate = f.bounded("frame_rate", 1.0, kMaxFrameRate, p.frame_rate);
  // Within [1, 10^4] by the frame rate's bounds.
  m.packets_per_row = f.has("packets_per_row")
                          ? static_cast<int>(f.integer("packets_per_row", 1, kMaxPacketsPerRow))
                          : static_cast<int>(std::max(1.0, std::round(m.frame_rate / 100.0)));
  m.frame_noise = f.non_negative("frame_noise", 0.0);
  m.relative_noise = f.non_negative("relative_noise", 0.0);
  // A row sums K frames of at most delta_limit counts into mice.csv's 32-bit counts.
  const long max_delta = INT_MAX / m.packets_per_row;
  m.delta_limit = f.has("delta_limit") ? static_cast<int>(f.integer("delta_limit", 0, max_delta))
                                       : std::min(m.delta_limit, static_cast<int>(max_delta));
  m.squal = f.bounded("squal", 0.0, 255.0, m.squal);
  m.squal_jitter = f.bounded("squal_jitter", 0.0, 255.0, 0.0);
  return m;
}

std::vector<std::string> sensor_names(const Fields& f, std::size_t count) {
  std::vector<std::string> names;
  if (!f.has("names")) {
    for (std::size_t i = 0; i < count; ++i) names.push_back(fmt::format("m{}", i + 1));
    return names;
  }
  const YAML::Node node = f.required("names");
  if (!node.IsSequence()) {
    f.fail("names", fmt::format("expected a list of names, found {}", describe_kind(node)));
  }
  if (node.size() != count) {
    f.fail("names",
           fmt::format("expected {} names (one per sensor), found {}", count, node.size()));
  }
  for (const auto& item : node) {
    if (!item.IsScalar()) f.fail_at(item, "names", "expected a name");
    names.push_back(item.Scalar());
  }
  return names;
}

// The nominal robot's sensors: a layout generator or an explicit list.
io::RobotConfig parse_sensors(const Source& source, const YAML::Node& node,
                              const SensorModel& model, bool gyro) {
  SensorMount prototype;
  prototype.cpi = model.cpi;
  prototype.max_speed = model.max_speed;
  io::RobotConfig config;
  std::vector<SensorMount> mounts;
  if (node.IsSequence()) {
    for (std::size_t i = 0; i < node.size(); ++i) {
      const Fields s(source, node[i], fmt::format("sensors[{}]", i),
                     {"name", "position", "yaw", "mirrored", "cpi"});
      SensorMount m = prototype;
      const auto p = s.numbers("position", 2);
      m.position = {p[0], p[1]};
      m.yaw = s.number("yaw");
      m.mirrored = s.boolean("mirrored", false);
      m.cpi = s.positive("cpi", m.cpi);
      config.names.push_back(s.text("name"));
      mounts.push_back(m);
    }
  } else {
    const Fields f(source, node, "sensors",
                   {"layout", "names", "angles_deg", "distance", "n", "radius", "theta"});
    const std::string layout = f.choice("layout", {"radial", "polygon"});
    if (layout == "radial") {
      for (const auto key : {"n", "radius", "theta"}) {
        if (f.has(key)) f.fail(key, "not used by layout 'radial' (it takes angles_deg, distance)");
      }
      const auto angles = f.numbers("angles_deg");
      const double d = f.positive("distance");
      for (const double a : angles) {
        // Sekimori & Miyazaki: position d (cos phi, sin phi), x axis radial.
        SensorMount m = prototype;
        m.position = d * Eigen::Vector2d(std::cos(to_radians(a)), std::sin(to_radians(a)));
        m.yaw = to_radians(a);
        mounts.push_back(m);
      }
    } else {
      for (const auto key : {"angles_deg", "distance"}) {
        if (f.has(key)) f.fail(key, "not used by layout 'polygon' (it takes n, radius, theta)");
      }
      const int n = static_cast<int>(f.integer("n", 1, kMaxSensors));
      const SensorArray polygon =
          regular_polygon(n, f.positive("radius"), f.number("theta", 0.0), prototype);
      mounts.assign(polygon.mounts().begin(), polygon.mounts().end());
    }
    config.names = sensor_names(f, mounts.size());
  }
  // One sensor takes its rotation from a gyro (the scenario's imu:).
  const std::size_t fewest = gyro ? 1 : 2;
  if (mounts.size() < fewest || mounts.size() > static_cast<std::size_t>(kMaxSensors)) {
    source.fail(node, fmt::format("key 'sensors': {} sensors, expected {} to {}{}", mounts.size(),
                                  fewest, kMaxSensors, gyro ? "" : " (1 with an imu:)"));
  }
  for (std::size_t i = 0; i < config.names.size(); ++i) {
    const std::string& name = config.names[i];
    if (!io::is_valid_sensor_name(name)) {
      source.fail(node, fmt::format("key 'sensors': invalid sensor name '{}': a name is {}",
                                    io::excerpt(name), io::kSensorNameRule));
    }
    if (std::find(config.names.begin(), config.names.begin() + static_cast<long>(i), name) !=
        config.names.begin() + static_cast<long>(i)) {
      source.fail(node, fmt::format("key 'sensors': duplicate sensor name '{}'", name));
    }
  }
  config.array = SensorArray(std::move(mounts));
  return config;
}

int sensor_index(const Fields& f, std::string_view key, const YAML::Node& at,
                 const io::RobotConfig& config) {
  if (!at.IsScalar())
    f.fail_at(at, key, fmt::format("expected a sensor name, found {}", describe_kind(at)));
  const auto index = config.index_of(at.Scalar());
  if (!index) {
    std::string names;
    for (const auto& n : config.names) names += (names.empty() ? "" : ", ") + n;
    f.fail_at(at, key,
              fmt::format("no sensor called '{}' (sensors: {})", io::excerpt(at.Scalar()), names));
  }
  return *index;
}

// `latency` (s, within +-latency_limit, default 0) and `jitter` (s, default
// 0; below the stream's row period `period`, so that its stamps stay in
// order: clock.hpp).
StreamTiming parse_timing(const Fields& f, double latency_limit, double period) {
  StreamTiming t;
  t.latency = f.bounded("latency", -latency_limit, latency_limit, 0.0);
  t.jitter = f.non_negative("jitter", 0.0);
  if (t.jitter >= period) {
    f.fail("jitter", fmt::format("must be less than the row period ({} s), so that the stamps "
                                 "stay in order (found {})",
                                 period, t.jitter));
  }
  return t;
}

// The real robot: the nominal one with the listed deviations, and its
// sensors' row latencies and jitters (`timing`, one per sensor).
io::RobotConfig parse_true_sensors(const Source& source, const YAML::Node& node,
                                   const io::RobotConfig& nominal, const SensorModel& model,
                                   std::vector<StreamTiming>& timing) {
  io::RobotConfig truth = nominal;
  if (!node.IsMap()) {
    source.fail(node, fmt::format("key 'true_sensors': expected a map from sensor names to "
                                  "deviations, found {}",
                                  describe_kind(node)));
  }
  std::vector<bool> seen(nominal.names.size(), false);
  for (const auto& entry : node) {
    if (!entry.first.IsScalar())
      source.fail(entry.first, "key 'true_sensors': a key is not a name");
    const std::string& name = entry.first.Scalar();
    const auto index = nominal.index_of(name);
    if (!index) {
      std::string names;
      for (const auto& n : nominal.names) names += (names.empty() ? "" : ", ") + n;
      source.fail(
          entry.first,
          fmt::format("key 'true_sensors': no sensor called '{}' (sensors: {})", name, names));
    }
    if (seen[static_cast<std::size_t>(*index)]) {
      source.fail(entry.first, fmt::format("key 'true_sensors': duplicate sensor '{}'", name));
    }
    seen[static_cast<std::size_t>(*index)] = true;
    const Fields f(source, entry.second, "true_sensors." + name,
                   {"position_error", "position_scale", "yaw_error", "scale", "mirrored", "cpi",
                    "latency", "jitter", "speed_scale"});
    SensorMount& m = truth.array[*index];
    m.position *= f.positive("position_scale", 1.0);
    if (f.has("position_error")) {
      const auto e = f.numbers("position_error", 2);
      m.position += Eigen::Vector2d(e[0], e[1]);
    }
    m.yaw += f.number("yaw_error", 0.0);
    if (f.has("scale")) {
      const auto s = f.numbers("scale", 2);
      if (!(s[0] > 0.0 && s[1] > 0.0)) f.fail("scale", "must be > 0");
      m.scale = {s[0], s[1]};
    }
    m.mirrored = f.boolean("mirrored", m.mirrored);
    m.cpi = f.positive("cpi", m.cpi);
    StreamTiming& t = timing[static_cast<std::size_t>(*index)];
    t = parse_timing(f, io::kMaxSensorLatency, model.row_period());
    m.latency = static_cast<real>(t.latency);
    // Counted over true displacement by ground speed: the simulator's counts
    // follow it, robot.true.yaml carries it, robot.yaml does not.
    if (f.has("speed_scale")) m.speed_scale = io::parse_speed_scale(f);
  }
  return truth;
}

// The noise the estimators should assume, written into both configs: the
// per-frame noise (additive, and relative at the rated speed) summed over a
// row of K frames, as a velocity over the row's duration:
//   sigma_v = sqrt(K (sigma_f^2 + (rho v_max k h)^2)) / (k K h),  k = cpi / 0.0254.
// Three significant digits: it is a figure a user would write down.
std::optional<double> config_noise(const SensorModel& m, const Fields& f) {
  if (m.frame_noise <= 0.0 && m.relative_noise <= 0.0) return std::nullopt;
  const double k = m.cpi / kMetresPerInch;
  const double h = 1.0 / m.frame_rate;
  const double rel = m.relative_noise * m.max_speed * k * h;
  const double per_frame = m.frame_noise * m.frame_noise + rel * rel;
  const double kk = static_cast<double>(m.packets_per_row);
  const double sigma = std::sqrt(kk * per_frame) / (k * kk * h);
  // Read back as config v1 will: a figure too small or too large for a
  // double there is refused here, naming the key that made it.
  const auto parsed = io::parse_number(fmt::format("{:.3g}", sigma));
  if (const auto* error = std::get_if<std::string>(&parsed)) {
    f.fail(m.frame_noise > 0.0 ? "frame_noise" : "relative_noise",
           fmt::format("the sensor noise it implies cannot be written to robot.yaml ({})", *error));
  }
  return std::get<double>(parsed);
}

DriveModel parse_drive(const Source& source, const YAML::Node& node, const SensorModel& sensor) {
  DriveModel d;
  d.rate = 1.0 / sensor.row_period();
  const Fields probe(source, node, "drive",
                     {"type", "wheel_distance", "wheel_angles_deg", "rate", "encoder_resolution",
                      "slip", "noise_speed", "noise_rate"});
  const std::string type =
      probe.choice("type", {"none", "omni3", "differential", "mecanum", "reference"});
  if (type == "none") {
    for (const auto key : {"wheel_distance", "wheel_angles_deg", "rate", "encoder_resolution",
                           "slip", "noise_speed", "noise_rate"}) {
      if (probe.has(key)) probe.fail(key, "not used by drive type 'none'");
    }
    return d;
  }
  d.rate = probe.bounded("rate", kMinRate, kMaxFrameRate, d.rate);
  d.noise_speed = probe.non_negative("noise_speed", 0.0);
  d.noise_rate = probe.non_negative("noise_rate", 0.0);
  if (type == "reference") {
    d.type = DriveType::kReference;
    for (const auto key : {"wheel_distance", "wheel_angles_deg", "encoder_resolution", "slip"}) {
      if (probe.has(key)) probe.fail(key, "not used by drive type 'reference'");
    }
    return d;
  }
  d.type = type == "omni3"     ? DriveType::kOmni3
           : type == "mecanum" ? DriveType::kMecanum
                               : DriveType::kDifferential;
  d.wheel_distance = probe.positive("wheel_distance");
  d.encoder_resolution = probe.non_negative("encoder_resolution", 0.0);
  const int wheels = d.wheel_count();
  if (d.type == DriveType::kOmni3) {
    const auto angles = probe.has("wheel_angles_deg") ? probe.numbers("wheel_angles_deg", 3)
                                                      : std::vector<double>{90.0, 210.0, 330.0};
    for (const double a : angles) d.wheel_angles.push_back(to_radians(a));
    Eigen::Matrix3d w;
    for (int j = 0; j < 3; ++j) {
      const double a = d.wheel_angles[static_cast<std::size_t>(j)];
      w.row(j) << -std::sin(a), std::cos(a), 1.0;
    }
    if (std::abs(w.determinant()) < 1e-6) {
      probe.fail("wheel_angles_deg",
                 "the three wheels cannot drive every twist (angles too close)");
    }
  } else if (probe.has("wheel_angles_deg")) {
    probe.fail("wheel_angles_deg", fmt::format("not used by drive type '{}'", type));
  }
  d.slip.base.assign(static_cast<std::size_t>(wheels), 0.0);
  if (const auto slip_node = probe.get("slip")) {
    const Fields s(source, *slip_node, "drive.slip",
                   {"base", "per_speed", "per_accel", "random", "random_time", "bursts"});
    if (const auto base = s.get("base")) {
      if (base->IsSequence()) {
        d.slip.base = s.numbers("base", static_cast<std::size_t>(wheels));
      } else {
        d.slip.base.assign(static_cast<std::size_t>(wheels), s.number("base"));
      }
      for (const double b : d.slip.base) {
        if (b <= -1.0) s.fail("base", fmt::format("must be > -1 (found {})", b));
      }
    }
    d.slip.per_speed = s.number("per_speed", 0.0);
    d.slip.per_accel = s.number("per_accel", 0.0);
    d.slip.random = s.non_negative("random", 0.0);
    d.slip.random_time = s.positive("random_time", d.slip.random_time);
    if (const auto bursts = s.get("bursts")) {
      if (!bursts->IsSequence()) {
        s.fail("bursts", fmt::format("expected a list of {{start, end, slip, wheel}}, found {}",
                                     describe_kind(*bursts)));
      }
      for (std::size_t i = 0; i < bursts->size(); ++i) {
        const Fields b(source, (*bursts)[i], fmt::format("drive.slip.bursts[{}]", i),
                       {"start", "end", "slip", "wheel"});
        SlipBurst burst;
        burst.start = b.bounded("start", 0.0, kMaxScenarioDuration);
        burst.end = b.bounded("end", 0.0, kMaxScenarioDuration);
        if (burst.end <= burst.start) {
          b.fail("end", fmt::format("must be after start ({} <= {})", burst.end, burst.start));
        }
        burst.slip = b.bounded("slip", -0.9, 10.0);
        burst.wheel = b.has("wheel") ? static_cast<int>(b.integer("wheel", 0, wheels - 1)) : -1;
        d.slip.bursts.push_back(burst);
      }
    }
  }
  return d;
}

Pose2 to_pose(const Fields& f, std::string_view key, const YAML::Node& node) {
  const auto v = f.to_numbers(key, node, 3);
  return {{v[0], v[1]}, v[2]};
}

// Lateral velocity a differential drive cannot produce, m/s (or m per unit).
constexpr double kLateralTolerance = 1e-9;

Motion parse_waypoints(const Fields& f, bool differential) {
  const YAML::Node list = f.required("waypoints");
  if (!list.IsSequence()) {
    f.fail("waypoints",
           fmt::format("expected a list of [x, y, heading], found {}", describe_kind(list)));
  }
  if (list.size() < 2) f.fail("waypoints", "at least two waypoints are needed");
  std::vector<Pose2> poses;
  for (const auto& item : list) poses.push_back(to_pose(f, "waypoints", item));
  const bool arc = f.has("interpolation") && f.choice("interpolation", {"linear", "arc"}) == "arc";
  PathLimits limits;
  limits.max_speed = f.positive("max_speed");
  limits.max_rate = f.positive("max_rate");
  limits.max_accel = f.positive("max_accel");
  limits.max_angular_accel = f.positive("max_angular_accel");
  const double pause = f.non_negative("pause", 0.0);
  for (std::size_t i = 0; i + 1 < poses.size(); ++i) {
    const Pose2& a = poses[i];
    const Pose2& b = poses[i + 1];
    const double turn = b.theta - a.theta;
    if (std::abs(turn) >= 2.0 * std::numbers::pi && arc) {
      f.fail_at(list[i + 1], "waypoints", "an arc segment cannot turn by 2 pi or more");
    }
    if (!differential) continue;
    // A differential drive moves along its heading or turns on the spot.
    double lateral = 0.0;
    if (arc) {
      lateral = std::abs(twist_between(a, b, 1.0).v.y());
    } else {
      const Eigen::Vector2d d = b.t - a.t;
      const Eigen::Vector2d heading(std::cos(a.theta), std::sin(a.theta));
      lateral = std::abs(heading.x() * d.y() - heading.y() * d.x());
      if (d.norm() > kLateralTolerance && std::abs(turn) > 0.0)
        lateral = std::max(lateral, d.norm());
    }
    if (lateral > kLateralTolerance) {
      f.fail_at(list[i + 1], "waypoints",
                fmt::format("segment {} -> {} needs sideways motion, which a differential drive "
                            "cannot make",
                            i + 1, i + 2));
    }
  }
  return WaypointPath(std::move(poses), arc ? Interpolation::kArc : Interpolation::kLinear, limits,
                      pause);
}

Motion parse_twists(const Source& source, const Fields& f, bool differential) {
  TwistProgram program;
  const YAML::Node list = f.required("segments");
  if (!list.IsSequence() || list.size() == 0) {
    f.fail("segments", fmt::format("expected a non-empty list of {{twist, duration}}, found {}",
                                   describe_kind(list)));
  }
  for (std::size_t i = 0; i < list.size(); ++i) {
    const Fields s(source, list[i], fmt::format("motion.segments[{}]", i), {"twist", "duration"});
    const auto x = s.numbers("twist", 3);
    if (differential && std::abs(x[1]) > 0.0) {
      s.fail("twist", "a differential drive cannot move sideways (vy must be 0)");
    }
    program.segments.push_back({{{x[0], x[1]}, x[2]}, duration_of(s, "duration")});
  }
  program.max_accel = f.non_negative("max_accel", 0.0);
  program.max_angular_accel = f.non_negative("max_angular_accel", 0.0);
  return program;
}

std::vector<Excitation::Sine> parse_sines(const Fields& f, std::string_view key) {
  std::vector<Excitation::Sine> sines;
  const auto node = f.get(key);
  if (!node) return sines;
  if (!node->IsSequence()) {
    f.fail(key, fmt::format("expected a list of [amplitude, frequency_hz, phase_rad], found {}",
                            describe_kind(*node)));
  }
  for (const auto& item : *node) {
    const auto v = f.to_numbers(key, item, 3);
    if (v[1] < 0.0) f.fail_at(item, key, fmt::format("frequency must be >= 0 (found {})", v[1]));
    sines.push_back({v[0], v[1], v[2]});
  }
  return sines;
}

Motion parse_sines_motion(const Fields& f, bool differential) {
  Excitation e;
  e.vx = parse_sines(f, "vx");
  e.vy = parse_sines(f, "vy");
  e.omega = parse_sines(f, "omega");
  if (f.has("offset")) {
    const auto o = f.numbers("offset", 3);
    e.offset = {{o[0], o[1]}, o[2]};
  }
  if (differential && (!e.vy.empty() || e.offset.v.y() != 0.0)) {
    f.fail(f.has("vy") ? "vy" : "offset", "a differential drive cannot move sideways");
  }
  e.duration = duration_of(f, "duration");
  e.fade = f.non_negative("fade", 0.0);
  if (2.0 * e.fade > e.duration) f.fail("fade", "longer than half the duration");
  return e;
}

Motion parse_motion(const Source& source, const YAML::Node& node, bool differential) {
  const Fields probe(source, node, "motion",
                     {"type", "waypoints", "interpolation", "max_speed", "max_rate", "max_accel",
                      "max_angular_accel", "pause", "segments", "vx", "vy", "omega", "offset",
                      "duration", "fade"});
  const std::string type = probe.choice("type", {"waypoints", "twists", "sines"});
  const auto allowed = [&](std::initializer_list<std::string_view> keys) {
    return Fields(source, node, "motion", keys);
  };
  if (type == "waypoints") {
    return parse_waypoints(allowed({"type", "waypoints", "interpolation", "max_speed", "max_rate",
                                    "max_accel", "max_angular_accel", "pause"}),
                           differential);
  }
  if (type == "twists") {
    return parse_twists(source, allowed({"type", "segments", "max_accel", "max_angular_accel"}),
                        differential);
  }
  return parse_sines_motion(allowed({"type", "vx", "vy", "omega", "offset", "duration", "fade"}),
                            differential);
}

void parse_faults(const Source& source, const YAML::Node& node, const io::RobotConfig& config,
                  double duration, std::vector<SensorFaults>& faults) {
  const Fields f(source, node, "faults", {"tracking_loss", "events"});
  if (const auto loss_node = f.get("tracking_loss")) {
    const Fields l(source, *loss_node, "faults.tracking_loss",
                   {"rate", "mean_duration", "retained", "squal_factor", "sensors"});
    TrackingLoss loss;
    l.required("rate");
    loss.rate = l.non_negative("rate", 0.0);
    loss.mean_duration = l.positive("mean_duration");
    if (l.has("retained")) {
      const auto r = l.numbers("retained", 2);
      if (r[0] < 0.0 || r[1] > 1.0 || r[0] > r[1]) {
        l.fail("retained", "expected [min, max] with 0 <= min <= max <= 1");
      }
      loss.retained_min = r[0];
      loss.retained_max = r[1];
    }
    loss.squal_factor = l.fraction("squal_factor", 1.0);
    std::vector<int> which;
    if (const auto sensors = l.get("sensors")) {
      if (!sensors->IsSequence()) {
        l.fail("sensors",
               fmt::format("expected a list of sensor names, found {}", describe_kind(*sensors)));
      }
      for (const auto& item : *sensors) which.push_back(sensor_index(l, "sensors", item, config));
    } else {
      for (int i = 0; i < config.array.size(); ++i) which.push_back(i);
    }
    for (const int i : which) faults[static_cast<std::size_t>(i)].tracking_loss = loss;
  }
  const auto events = f.get("events");
  if (!events) return;
  if (!events->IsSequence()) {
    f.fail("events",
           fmt::format("expected a list of fault events, found {}", describe_kind(*events)));
  }
  for (std::size_t i = 0; i < events->size(); ++i) {
    const YAML::Node item = (*events)[i];
    const std::string path = fmt::format("faults.events[{}]", i);
    const Fields probe(source, item, path,
                       {"type", "sensor", "start", "end", "squal", "lift_flag", "retained", "rate",
                        "magnitude", "scale", "ramp"});
    const std::string type = probe.choice("type", {"liftoff", "dirty", "spikes", "stuck", "drift"});
    const Fields e =
        type == "liftoff"
            ? Fields(source, item, path, {"type", "sensor", "start", "end", "squal", "lift_flag"})
        : type == "dirty"
            ? Fields(source, item, path, {"type", "sensor", "start", "end", "squal", "retained"})
        : type == "spikes"
            ? Fields(source, item, path, {"type", "sensor", "start", "end", "rate", "magnitude"})
        : type == "drift"
            ? Fields(source, item, path, {"type", "sensor", "start", "end", "scale", "ramp"})
            : Fields(source, item, path, {"type", "sensor", "start", "end"});
    FaultWindow w;
    const int sensor = sensor_index(e, "sensor", e.required("sensor"), config);
    w.start = e.number("start");
    w.end = e.number("end");
    if (w.start < 0.0) e.fail("start", fmt::format("must be >= 0 (found {})", w.start));
    if (w.end <= w.start) {
      e.fail("end", fmt::format("must be after start ({} <= {})", w.end, w.start));
    }
    if (w.start >= duration) {
      e.fail("start", fmt::format("after the end of the run ({} s)", duration));
    }
    const auto squal = [&](int fallback) {
      return e.has("squal") ? static_cast<int>(e.integer("squal", 0, 255)) : fallback;
    };
    if (type == "liftoff") {
      w.kind = kFaultLiftoff;
      w.squal = squal(3);
      w.lift_flag = e.boolean("lift_flag", true);
    } else if (type == "dirty") {
      w.kind = kFaultDirty;
      w.squal = squal(15);
      e.required("retained");
      w.retained = e.fraction("retained", 0.0);
    } else if (type == "spikes") {
      w.kind = kFaultSpike;
      w.rate = e.positive("rate");
      w.magnitude = e.positive("magnitude");
    } else if (type == "drift") {
      w.kind = kFaultDrift;
      w.scale = e.positive("scale");
      w.ramp = e.non_negative("ramp", 0.0);
    } else {
      w.kind = kFaultStuck;
    }
    faults[static_cast<std::size_t>(sensor)].windows.push_back(w);
  }
}

// `camera: {mode, rate, noise, heading_noise, latency, jitter, drop,
// outliers}`: a ceiling camera (mode positions, the default) or motion
// capture (mode mocap: heading_noise required).
CameraModel parse_camera(const Source& source, const YAML::Node& node, double frame_rate) {
  const Fields f(
      source, node, "camera",
      {"mode", "rate", "noise", "heading_noise", "latency", "jitter", "drop", "outliers"});
  CameraModel c;
  c.enabled = true;
  if (f.has("mode") && f.choice("mode", {"positions", "mocap"}) == "mocap") {
    c.mode = CameraMode::kMocap;
  }
  c.rate = f.bounded("rate", kMinRate, kMaxFrameRate);
  f.required("noise");
  c.noise = f.non_negative("noise", 0.0);
  if (c.mode == CameraMode::kMocap) {
    f.required("heading_noise");
    c.heading_noise = f.non_negative("heading_noise", 0.0);
  } else if (f.has("heading_noise")) {
    f.fail("heading_noise", "not used by camera mode 'positions' (no theta; mode: mocap has one)");
  }
  const double period = static_cast<double>(frames_per_row(frame_rate, c.rate)) / frame_rate;
  const StreamTiming timing = parse_timing(f, io::kMaxStreamLatency, period);
  c.latency = timing.latency;
  c.jitter = timing.jitter;
  c.drop = f.fraction("drop", 0.0);
  if (const auto o = f.get("outliers")) {
    const Fields of(source, *o, "camera.outliers", {"rate", "magnitude"});
    of.required("rate");
    c.outlier_rate = of.fraction("rate", 0.0);
    c.outlier_magnitude = of.positive("magnitude");
  }
  return c;
}

// `imu: {rate, scale, bias, bias_walk, noise_density, max_rate, latency,
// latency_error}`: the gyro as built. robot.yaml gets what its user knows
// (the noise, the full scale and the latency less latency_error, from the
// part's datasheet and the firmware; scale 1 and bias 0), robot.true.yaml
// the true scale, bias and latency.
GyroSpec parse_imu(const Source& source, const YAML::Node& node) {
  const Fields f(source, node, "imu",
                 {"rate", "scale", "bias", "bias_walk", "noise_density", "max_rate", "latency",
                  "latency_error", "faults"});
  GyroSpec g;
  g.enabled = true;
  g.rate = f.bounded("rate", kMinRate, kMaxFrameRate, g.rate);
  g.scale = f.bounded("scale", 0.5, 2.0, g.scale);
  g.bias = f.bounded("bias", -1.0, 1.0, g.bias);
  g.bias_walk = f.non_negative("bias_walk", g.bias_walk);
  g.noise_density = f.positive("noise_density", g.noise_density);
  g.max_rate = f.positive("max_rate", g.max_rate);
  g.latency = f.bounded("latency", 0.0, 1.0, g.latency);
  g.latency_error = f.bounded("latency_error", -0.1, 0.1, g.latency_error);
  if (const auto faults = f.get("faults")) {
    if (!faults->IsSequence()) {
      f.fail("faults",
             fmt::format("expected a list of gyro faults, found {}", describe_kind(*faults)));
    }
    for (std::size_t i = 0; i < faults->size(); ++i) {
      const YAML::Node item = (*faults)[i];
      const std::string path = fmt::format("imu.faults[{}]", i);
      const std::string type = Fields(source, item, path, {"type", "start", "end", "step"})
                                   .choice("type", {"stuck", "bias_step"});
      const Fields e = type == "stuck" ? Fields(source, item, path, {"type", "start", "end"})
                                       : Fields(source, item, path, {"type", "start", "step"});
      GyroFault fault;
      fault.start = e.bounded("start", 0.0, kMaxScenarioDuration);
      if (type == "stuck") {
        fault.kind = GyroFault::kStuck;
        fault.end = e.bounded("end", 0.0, kMaxScenarioDuration);
        if (fault.end <= fault.start) {
          e.fail("end", fmt::format("must be after start ({} <= {})", fault.end, fault.start));
        }
      } else {
        fault.kind = GyroFault::kBiasStep;
        fault.step = e.bounded("step", -1.0, 1.0);
        fault.end = kMaxScenarioDuration;
      }
      g.faults.push_back(fault);
    }
  }
  return g;
}

GyroOptions believed_gyro(const GyroSpec& g) {
  GyroOptions o;
  o.noise_density = static_cast<real>(g.noise_density);
  o.max_rate = static_cast<real>(g.max_rate);
  o.latency = g.latency - g.latency_error;
  if (g.bias_walk > 0.0) o.bias_random_walk = static_cast<real>(g.bias_walk);
  return o;
}

}  // namespace

std::int64_t Scenario::frame_count() const {
  const double frames = duration * sensor_model.frame_rate;
  // Checked before the casts; parse_scenario refuses such scenarios with the key named.
  if (!(frames <= kMaxScenarioFrames) || sensor_model.packets_per_row < 1) {
    throw io::Error(fmt::format("scenario '{}': {} s at {} frames/s: more than {:.3g} frames", name,
                                duration, sensor_model.frame_rate, kMaxScenarioFrames));
  }
  const auto k = static_cast<std::int64_t>(sensor_model.packets_per_row);
  // Whole rows; the 1e-9 keeps a duration that is a whole number of rows
  // from gaining one through rounding.
  const auto rows = static_cast<std::int64_t>(std::ceil(frames / static_cast<double>(k) - 1e-9));
  return std::max<std::int64_t>(1, rows) * k;
}

Scenario parse_scenario(std::string_view yaml, std::string_view source_name) {
  const Source source(source_name);
  const YAML::Node root = io::load_yaml(yaml, source_name);
  if (root.IsNull()) source.fail("empty scenario");
  if (!root.IsMap())
    source.fail(root, fmt::format("expected a map, found {}", describe_kind(root)));

  // The version first: a newer file may have keys this reader does not know.
  for (const auto& entry : root) {
    if (entry.first.IsScalar() && entry.first.Scalar() == "version") {
      const YAML::Node& v = entry.second;
      if (!v.IsScalar() || v.Scalar() != std::to_string(kScenarioVersion)) {
        source.fail(v, fmt::format("key 'version': {} is not supported (expected {})",
                                   v.IsScalar() ? v.Scalar() : describe_kind(v), kScenarioVersion));
      }
    }
  }
  const Fields top(
      source, root, "",
      {"version", "name", "description", "duration", "truth_rate", "sensor_model", "sensors",
       "true_sensors", "drive", "wheels", "motion", "faults", "camera", "imu", "unobservable"});
  top.required("version");

  Scenario s;
  s.name = top.text("name");
  if (top.has("description")) s.description = top.text("description");
  if (const auto u = top.get("unobservable")) {
    if (!u->IsSequence()) {
      top.fail("unobservable",
               fmt::format("expected a list of texts, found {}", describe_kind(*u)));
    }
    for (std::size_t i = 0; i < u->size(); ++i) {
      const YAML::Node item = (*u)[i];
      if (!item.IsScalar()) {
        top.fail("unobservable",
                 fmt::format("item {}: expected a text, found {}", i, describe_kind(item)));
      }
      s.unobservable.push_back(item.Scalar());
    }
  }
  const Fields model_fields(
      source, top.required("sensor_model"), "sensor_model",
      {"preset", "cpi", "frame_rate", "max_speed", "packets_per_row", "frame_noise",
       "relative_noise", "delta_limit", "squal", "squal_jitter"});
  s.sensor_model = parse_sensor_model(model_fields);
  s.nominal =
      parse_sensors(source, top.required("sensors"), s.sensor_model, top.get("imu").has_value());
  const auto noise = config_noise(s.sensor_model, model_fields);
  for (int i = 0; i < s.nominal.array.size(); ++i) s.nominal.array[i].noise = noise;
  s.truth = s.nominal;
  s.sensor_timing.assign(static_cast<std::size_t>(s.nominal.array.size()), {});
  if (const auto t = top.get("true_sensors")) {
    s.truth = parse_true_sensors(source, *t, s.nominal, s.sensor_model, s.sensor_timing);
  }
  if (const auto d = top.get("drive")) s.drive = parse_drive(source, *d, s.sensor_model);
  if (const auto w = top.get("wheels")) {
    const Fields f(source, *w, "wheels", {"latency", "jitter"});
    if (s.drive.type == DriveType::kNone) {
      top.fail("wheels", "no drive, so no wheels.csv to stamp (give drive:)");
    }
    const double fps = s.sensor_model.frame_rate;
    s.wheel_timing = parse_timing(f, io::kMaxStreamLatency,
                                  static_cast<double>(frames_per_row(fps, s.drive.rate)) / fps);
    if (s.wheel_timing.latency != 0.0) s.truth.wheels_latency = s.wheel_timing.latency;
  }
  if (const auto c = top.get("camera")) {
    s.camera = parse_camera(source, *c, s.sensor_model.frame_rate);
    // robot.true.yaml knows the camera's latency; robot.yaml believes none.
    if (s.camera.latency != 0.0) s.truth.camera_latency = s.camera.latency;
  }
  if (const auto g = top.get("imu")) {
    s.imu = parse_imu(source, *g);
    s.nominal.imu = believed_gyro(s.imu);
    s.truth.imu = s.nominal.imu;
    s.truth.imu->scale = static_cast<real>(s.imu.scale);
    s.truth.imu->bias = static_cast<real>(s.imu.bias);
    s.truth.imu->latency = s.imu.latency;
  }
  s.motion = parse_motion(source, top.required("motion"), s.drive.type == DriveType::kDifferential);
  s.truth_rate = top.bounded("truth_rate", kMinRate, kMaxFrameRate, 100.0);
  const double motion_time = sim::duration(s.motion);
  if (!(motion_time <= kMaxScenarioDuration)) {
    top.fail("motion", fmt::format("lasts {} s, at most {} s", motion_time, kMaxScenarioDuration));
  }
  s.duration = motion_time;
  if (top.has("duration")) {
    s.duration = duration_of(top, "duration");
    if (s.duration < motion_time) {
      top.fail("duration",
               fmt::format("shorter than the motion ({} s < {} s)", s.duration, motion_time));
    }
  }
  if (const double frames = s.duration * s.sensor_model.frame_rate; frames > kMaxScenarioFrames) {
    top.fail(top.has("duration") ? "duration" : "motion",
             fmt::format("{} s at {} frames/s is {:.3g} frames, at most {:.3g}", s.duration,
                         s.sensor_model.frame_rate, frames, kMaxScenarioFrames));
  }
  s.faults.assign(static_cast<std::size_t>(s.nominal.array.size()), {});
  if (const auto f = top.get("faults")) parse_faults(source, *f, s.nominal, s.duration, s.faults);

  // Both configs must be writable as config v1 (the writer checks ranges).
  try {
    (void)io::format_config(s.nominal);
    (void)io::format_config(s.truth);
  } catch (const io::Error& e) {
    source.fail(fmt::format("the robot it describes is not a valid config: {}", e.what()));
  }
  return s;
}

std::vector<std::string> builtin_scenarios() {
  std::vector<std::string> names;
  for (std::size_t i = 0; i < detail::kBuiltinScenarioCount; ++i) {
    names.emplace_back(detail::kBuiltinScenarios[i].name);
  }
  std::sort(names.begin(), names.end());
  return names;
}

std::string_view builtin_scenario_text(std::string_view name) {
  for (std::size_t i = 0; i < detail::kBuiltinScenarioCount; ++i) {
    if (detail::kBuiltinScenarios[i].name == name) return detail::kBuiltinScenarios[i].text;
  }
  return {};
}

Scenario load_scenario(std::string_view name_or_path) {
  if (const auto text = builtin_scenario_text(name_or_path); !text.empty()) {
    return parse_scenario(text, fmt::format("{}.yaml (built in)", name_or_path));
  }
  const std::filesystem::path path{std::string(name_or_path)};
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    std::string names;
    for (const auto& n : builtin_scenarios()) names += (names.empty() ? "" : ", ") + n;
    throw io::Error(fmt::format("scenario '{}': not a built-in scenario ({}) and no such file",
                                name_or_path, names));
  }
  return parse_scenario(io::read_bounded(path, io::kMaxYamlBytes, "a moa scenario"), path.string());
}

}  // namespace moa::sim
