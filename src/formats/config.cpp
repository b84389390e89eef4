#include "moa/formats/config.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <span>
#include <sstream>
#include <system_error>

#include "moa/formats/atomic_file.hpp"
#include "moa/formats/csv.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/read_file.hpp"
#include "moa/formats/yaml.hpp"

namespace moa::io {
namespace {

constexpr int kConfigVersion = 1;

// Prefixes every message with where it is: "FILE: " or "FILE: sensor 'm1': ".
// For configs built in code (format_config); files are read by YamlFields.
class Context {
 public:
  Context(std::string_view source, std::string where) : source_(source), where_(std::move(where)) {}
  [[noreturn]] void fail(std::string_view what) const {
    if (where_.empty()) throw Error(printable(fmt::format("{}: {}", source_, what)));
    throw Error(printable(fmt::format("{}: {}: {}", source_, where_, what)));
  }
  [[noreturn]] void fail_key(std::string_view key, std::string_view what) const {
    fail(fmt::format("key '{}': {}", key, what));
  }
  std::string_view source() const { return source_; }

 private:
  std::string_view source_;
  std::string where_;
};

}  // namespace

bool is_valid_sensor_name(std::string_view name) {
  if (name.empty() || name.size() > kMaxSensorName) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '.' || c == '-';
  });
}

namespace {

// "speeds[2]: ..." for a refused table: the rule it breaks, the knot and its values.
std::string speed_scale_message(const SpeedScale& s, SpeedScale::Error e) {
  const int k = s.error_knot();
  switch (e) {
    case SpeedScale::Error::kTooFewKnots:
    case SpeedScale::Error::kTooManyKnots:
      return fmt::format("{} knots: {} (at least {}, at most {})", s.size(), describe(e),
                         SpeedScale::kMinKnots, SpeedScale::kMaxKnots);
    case SpeedScale::Error::kSizeMismatch:
      return describe(e);
    case SpeedScale::Error::kSpeedNotFinite:
      return fmt::format("speeds[{}]: must be a finite number >= 0 (found {})", k, s.speed(k));
    case SpeedScale::Error::kSpeedsNotIncreasing:
      return fmt::format("speeds[{}]: must be > speeds[{}] (found {} after {})", k, k - 1,
                         s.speed(k), s.speed(k - 1));
    case SpeedScale::Error::kRatioOutOfRange:
      return fmt::format("ratios[{}]: must be within [{}, {}] (found {})", k, SpeedScale::kMinRatio,
                         SpeedScale::kMaxRatio, s.ratio_at(k));
    case SpeedScale::Error::kNotMonotone:
      return fmt::format(
          "between speeds[{0}] and speeds[{1}]: {2} (ratio falls from {3} to {4} over {5}..{6} "
          "m/s)",
          k - 1, k, describe(e), s.ratio_at(k - 1), s.ratio_at(k), s.speed(k - 1), s.speed(k));
  }
  return describe(e);
}

// Range checks on values, shared by parsing (bad input) and formatting (a
// config built in code must not produce a file that cannot be read back).
void check_mount(const Context& context, const SensorMount& m) {
  if (!std::isfinite(m.position.x()) || !std::isfinite(m.position.y())) {
    context.fail_key("position", "not finite");
  }
  if (!std::isfinite(m.yaw)) context.fail_key("yaw", "not finite");
  if (!std::isfinite(m.cpi) || m.cpi <= 0.0) {
    context.fail_key("cpi", fmt::format("must be > 0 (found {})", m.cpi));
  }
  for (int i = 0; i < 2; ++i) {
    if (!std::isfinite(m.scale[i]) || m.scale[i] <= 0.0) {
      context.fail_key("scale", fmt::format("must be > 0 (found {})", m.scale[i]));
    }
  }
  if (m.max_speed && (!std::isfinite(*m.max_speed) || *m.max_speed <= 0.0)) {
    context.fail_key("max_speed", fmt::format("must be > 0 (found {})", *m.max_speed));
  }
  if (m.noise && (!std::isfinite(*m.noise) || *m.noise < 0.0)) {
    context.fail_key("noise", fmt::format("must be >= 0 (found {})", *m.noise));
  }
  if (!(std::abs(m.latency) <= kMaxSensorLatency)) {
    context.fail_key("latency", fmt::format("must be within -{0}..{0} s (found {1})",
                                            kMaxSensorLatency, m.latency));
  }
  if (const auto e = m.speed_scale.error()) {
    context.fail_key("speed_scale", speed_scale_message(m.speed_scale, *e));
  }
}

void check_count(const Context& context, std::size_t n) {
  if (n == 0) context.fail("no sensors (key 'sensors' is an empty list)");
  if (n > static_cast<std::size_t>(kMaxSensors)) {
    context.fail(fmt::format("{} sensors, at most {} are supported", n, kMaxSensors));
  }
}

std::string sensor_label(std::size_t index, const std::string& name) {
  return name.empty() ? fmt::format("sensor {}", index + 1) : fmt::format("sensor '{}'", name);
}

// The sensor's name, read first so that every later message can say which sensor it is.
std::string sensor_name(const YamlSource& source, const YAML::Node& node, std::size_t index) {
  const std::string unnamed = sensor_label(index, {});
  if (!node.IsMap()) {
    source.fail(node, fmt::format("{}: expected a map, found {}", unnamed, describe_kind(node)));
  }
  for (const auto& entry : node) {
    if (!entry.first.IsScalar() || entry.first.Scalar() != "name") continue;
    const YAML::Node& value = entry.second;
    if (!value.IsScalar()) {
      source.fail(value, fmt::format("{}: key 'name': expected a name, found {}", unnamed,
                                     describe_kind(value)));
    }
    if (!is_valid_sensor_name(value.Scalar())) {
      source.fail(value, fmt::format("{}: key 'name': invalid name '{}': a name is {}", unnamed,
                                     excerpt(value.Scalar()), kSensorNameRule));
    }
    return value.Scalar();
  }
  source.fail(node, fmt::format("{}: missing key 'name'", unnamed));
}

SensorMount parse_sensor(const YamlSource& source, const YAML::Node& node, std::size_t index,
                         std::string& name) {
  name = sensor_name(source, node, index);
  const YamlFields f(source, node, "",
                     {"name", "position", "yaw", "cpi", "scale", "mirrored", "max_speed", "noise",
                      "latency", "speed_scale"},
                     sensor_label(index, name));
  SensorMount m;
  const auto position = f.numbers("position", 2);
  m.position = {position[0], position[1]};
  m.yaw = f.number("yaw");
  m.cpi = f.positive("cpi");
  if (f.has("scale")) {
    const auto scale = f.numbers("scale", 2);
    if (!(scale[0] > 0.0 && scale[1] > 0.0)) {
      f.fail("scale", fmt::format("must be > 0 (found [{}, {}])", scale[0], scale[1]));
    }
    m.scale = {scale[0], scale[1]};
  }
  m.mirrored = f.boolean("mirrored", m.mirrored);
  if (f.has("max_speed")) m.max_speed = f.positive("max_speed");
  if (f.has("noise")) m.noise = f.non_negative("noise", 0.0);
  m.latency = static_cast<real>(f.bounded("latency", -kMaxSensorLatency, kMaxSensorLatency, 0.0));
  m.speed_scale = parse_speed_scale(f);
  check_mount(Context(source.name(), sensor_label(index, name)), m);
  return m;
}

// Plain YAML when the name reads back as the same string, double-quoted
// otherwise ("null", "-x", "&a" and the like would not).
std::string yaml_name(const std::string& name) {
  const bool plain_chars = std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '.' || c == '-' || c == '/' || c == '+';
  });
  const char first = name.empty() ? '\0' : name.front();
  const bool plain_start = (first >= 'a' && first <= 'z') || (first >= 'A' && first <= 'Z') ||
                           (first >= '0' && first <= '9') || first == '_';
  static constexpr std::array<std::string_view, 4> kNulls{"null", "Null", "NULL", "~"};
  if (plain_chars && plain_start && std::find(kNulls.begin(), kNulls.end(), name) == kNulls.end()) {
    return name;
  }
  std::string quoted = "\"";
  for (const char c : name) {
    if (c == '"' || c == '\\') quoted += '\\';
    quoted += c;
  }
  quoted += '"';
  return quoted;
}

// `limits: {accel: m/s^2, angular_accel: rad/s^2}`, each optional (a key
// left out keeps RobotLimits' default).
RobotLimits parse_limits(const YamlSource& source, const YAML::Node& node) {
  const YamlFields f(source, node, "limits", {"accel", "angular_accel"});
  RobotLimits limits;
  limits.accel = f.positive("accel", limits.accel);
  limits.angular_accel = f.positive("angular_accel", limits.angular_accel);
  if (auto e = limits.validate()) {
    e->prefix("limits");
    source.fail(node, e->message());
  }
  return limits;
}

// `camera: {latency: S}` or `wheels: {latency: S}`: the stream's row t minus
// the true time of what it reports (s).
double parse_latency(const YamlSource& source, const YAML::Node& node, const char* key) {
  const YamlFields f(source, node, key, {"latency"});
  return f.bounded("latency", -kMaxStreamLatency, kMaxStreamLatency, 0.0);
}

// `imu: {scale, bias, noise_density, ...}`, each optional (GyroOptions'
// defaults).
GyroOptions parse_imu(const YamlSource& source, const YAML::Node& node) {
  const YamlFields f(source, node, "imu",
                     {"scale", "bias", "noise_density", "bias_random_walk", "bias_sigma",
                      "scale_sigma", "mount_yaw_sigma", "max_rate", "latency", "latency_sigma"});
  GyroOptions imu;
  imu.scale = static_cast<real>(f.positive("scale", imu.scale));
  imu.bias = static_cast<real>(f.number("bias", imu.bias));
  imu.noise_density = static_cast<real>(f.positive("noise_density", imu.noise_density));
  imu.bias_random_walk =
      static_cast<real>(f.non_negative("bias_random_walk", imu.bias_random_walk));
  imu.bias_sigma = static_cast<real>(f.positive("bias_sigma", imu.bias_sigma));
  imu.scale_sigma = static_cast<real>(f.positive("scale_sigma", imu.scale_sigma));
  imu.mount_yaw_sigma = static_cast<real>(f.positive("mount_yaw_sigma", imu.mount_yaw_sigma));
  imu.max_rate = static_cast<real>(f.positive("max_rate", imu.max_rate));
  imu.latency = f.bounded("latency", -1.0, 1.0, imu.latency);
  imu.latency_sigma = static_cast<real>(f.positive("latency_sigma", imu.latency_sigma));
  if (auto e = imu.validate()) {
    e->prefix("imu");
    source.fail(node, e->message());
  }
  return imu;
}

}  // namespace

std::optional<int> RobotConfig::index_of(std::string_view name) const {
  const auto it = std::find(names.begin(), names.end(), name);
  if (it == names.end()) return std::nullopt;
  return static_cast<int>(it - names.begin());
}

RobotConfig parse_config(std::string_view yaml, std::string_view source_name) {
  const YamlSource source(source_name);
  const YAML::Node root = load_yaml(yaml, source_name);
  if (root.IsNull()) source.fail("empty config (expected keys 'version' and 'sensors')");
  if (!root.IsMap())
    source.fail(root, fmt::format("expected a map, found {}", describe_kind(root)));

  // The version before anything else: a newer file may well have keys this
  // reader does not know, and "unsupported version" is the useful message.
  bool has_version = false;
  for (const auto& entry : root) {
    if (!entry.first.IsScalar() || entry.first.Scalar() != "version") continue;
    has_version = true;
    const YAML::Node& v = entry.second;
    if (!v.IsScalar()) {
      source.fail(v, fmt::format("key 'version': expected an integer, found {}", describe_kind(v)));
    }
    if (v.Scalar() != std::to_string(kConfigVersion)) {
      source.fail(v, fmt::format("version {} is not supported (expected {})", excerpt(v.Scalar()),
                                 kConfigVersion));
    }
  }
  if (!has_version) source.fail(root, "missing key 'version'");

  const YamlFields top(source, root, "",
                       {"version", "sensors", "limits", "imu", "camera", "wheels"});
  const YAML::Node sensors = top.required("sensors");
  if (!sensors.IsSequence()) {
    top.fail("sensors",
             fmt::format("expected a list of sensors, found {}", describe_kind(sensors)));
  }
  check_count(Context(source_name, {}), sensors.size());

  RobotConfig config;
  std::vector<SensorMount> mounts;
  for (std::size_t i = 0; i < sensors.size(); ++i) {
    std::string name;
    mounts.push_back(parse_sensor(source, sensors[i], i, name));
    if (config.index_of(name)) {
      source.fail(sensors[i], fmt::format("duplicate sensor name '{}'", name));
    }
    config.names.push_back(std::move(name));
  }
  config.array = SensorArray(std::move(mounts));
  if (const auto limits = top.get("limits")) config.limits = parse_limits(source, *limits);
  if (const auto imu = top.get("imu")) config.imu = parse_imu(source, *imu);
  if (const auto camera = top.get("camera"))
    config.camera_latency = parse_latency(source, *camera, "camera");
  if (const auto wheels = top.get("wheels"))
    config.wheels_latency = parse_latency(source, *wheels, "wheels");
  return config;
}

RobotConfig read_config(const std::filesystem::path& path) {
  return parse_config(read_bounded(path, kMaxYamlBytes, "a moa robot config"), path.string());
}

std::string format_config(const RobotConfig& config) {
  const Context context("config", {});
  const std::size_t n = config.array.mounts().size();
  if (config.names.size() != n) {
    context.fail(fmt::format("{} names for {} sensors", config.names.size(), n));
  }
  check_count(context, n);

  // "{}" is fmt's shortest representation that reads back as the same double;
  // -0 is written as 0 (equal as numbers, and no one writes "-0" by hand).
  const auto num = [](double v) { return v == 0.0 ? 0.0 : v; };
  std::string out = fmt::format("version: {}\nsensors:\n", kConfigVersion);
  for (std::size_t i = 0; i < n; ++i) {
    const std::string& name = config.names[i];
    const SensorMount& m = config.array.mounts()[i];
    const Context sensor(context.source(), sensor_label(i, is_valid_sensor_name(name) ? name : ""));
    if (!is_valid_sensor_name(name)) {
      sensor.fail_key(
          "name", fmt::format("invalid name '{}': a name is {}", excerpt(name), kSensorNameRule));
    }
    if (config.index_of(name) != static_cast<int>(i)) {
      context.fail(fmt::format("duplicate sensor name '{}'", name));
    }
    check_mount(sensor, m);
    out += fmt::format("  - name: {}\n", yaml_name(name));
    out += fmt::format("    position: [{}, {}]\n", num(m.position.x()), num(m.position.y()));
    out += fmt::format("    yaw: {}\n", num(m.yaw));
    out += fmt::format("    cpi: {}\n", m.cpi);
    out += fmt::format("    scale: [{}, {}]\n", m.scale.x(), m.scale.y());
    out += fmt::format("    mirrored: {}\n", m.mirrored);
    if (m.max_speed) out += fmt::format("    max_speed: {}\n", *m.max_speed);
    if (m.noise) out += fmt::format("    noise: {}\n", *m.noise);
    if (m.latency != 0) out += fmt::format("    latency: {}\n", m.latency);
    if (m.speed_scale.active()) {
      std::string speeds, ratios;
      for (int k = 0; k < m.speed_scale.size(); ++k) {
        speeds += fmt::format("{}{}", k ? ", " : "", m.speed_scale.speed(k));
        ratios += fmt::format("{}{}", k ? ", " : "", m.speed_scale.ratio_at(k));
      }
      out +=
          fmt::format("    speed_scale:\n      speeds: [{}]\n      ratios: [{}]\n", speeds, ratios);
    }
  }
  if (config.limits) {
    if (auto e = config.limits->validate()) {
      e->prefix("limits");
      context.fail(e->message());
    }
    out += fmt::format("limits:\n  accel: {}\n  angular_accel: {}\n", config.limits->accel,
                       config.limits->angular_accel);
  }
  if (config.imu) {
    const GyroOptions& g = *config.imu;
    if (auto e = g.validate()) {
      e->prefix("imu");
      context.fail(e->message());
    }
    out += fmt::format(
        "imu:\n  scale: {}\n  bias: {}\n  noise_density: {}\n  bias_random_walk: {}\n"
        "  bias_sigma: {}\n  scale_sigma: {}\n  mount_yaw_sigma: {}\n  max_rate: {}\n"
        "  latency: {}\n",
        g.scale, num(g.bias), g.noise_density, g.bias_random_walk, g.bias_sigma, g.scale_sigma,
        g.mount_yaw_sigma, g.max_rate, num(g.latency));
  }
  const auto stream = [&](const char* key, const std::optional<double>& latency) {
    if (!latency) return;
    if (!(std::abs(*latency) <= kMaxStreamLatency)) {
      context.fail(fmt::format("{0}: latency must be within -{1}..{1} s (found {2})", key,
                               kMaxStreamLatency, *latency));
    }
    out += fmt::format("{}:\n  latency: {}\n", key, num(*latency));
  };
  stream("camera", config.camera_latency);
  stream("wheels", config.wheels_latency);
  return out;
}

SpeedScale parse_speed_scale(const YamlFields& f) {
  const auto node = f.get("speed_scale");
  if (!node) return {};
  const YamlFields s(f.source(), *node, f.full("speed_scale"), {"speeds", "ratios"}, f.label());
  const std::vector<double> speeds = s.numbers("speeds");
  const std::vector<double> ratios = s.numbers("ratios");
  const auto size = [&](const char* key, std::size_t n) {
    if (n < static_cast<std::size_t>(SpeedScale::kMinKnots) ||
        n > static_cast<std::size_t>(SpeedScale::kMaxKnots)) {
      s.fail(key, fmt::format("expected {} to {} numbers, found {}", SpeedScale::kMinKnots,
                              SpeedScale::kMaxKnots, n));
    }
  };
  size("speeds", speeds.size());
  size("ratios", ratios.size());
  if (speeds.size() != ratios.size()) {
    s.fail("ratios", fmt::format("expected one ratio per speed ({}), found {}", speeds.size(),
                                 ratios.size()));
  }
  std::array<real, SpeedScale::kMaxKnots> sp{}, ra{};
  std::copy(speeds.begin(), speeds.end(), sp.begin());
  std::copy(ratios.begin(), ratios.end(), ra.begin());
  const int n = static_cast<int>(speeds.size());
  SpeedScale table(sp.data(), ra.data(), n, n);
  if (const auto e = table.error()) {
    f.fail("speed_scale", speed_scale_message(table, *e));
  }
  return table;
}

void write_config(const RobotConfig& config, const std::filesystem::path& path) {
  std::string text = format_config(config);
  AtomicFile file(path);
  file.stream() << text;
  file.commit();
}

}  // namespace moa::io
