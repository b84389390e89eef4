#include "moa/io/config.hpp"

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

#include "moa/io/atomic_file.hpp"
#include "moa/io/csv.hpp"
#include "moa/io/error.hpp"

namespace moa::io {
namespace {

constexpr int kConfigVersion = 1;

constexpr std::array<std::string_view, 3> kTopKeys{"version", "sensors", "limits"};
constexpr std::array<std::string_view, 2> kLimitKeys{"accel", "angular_accel"};
constexpr std::array<std::string_view, 8> kSensorKeys{"name",  "position", "yaw",       "cpi",
                                                      "scale", "mirrored", "max_speed", "noise"};
constexpr std::array<std::string_view, 4> kRequiredSensorKeys{"name", "position", "yaw", "cpi"};

// Prefixes every message with where it is: "FILE: " or "FILE: sensor 'm1': ".
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

std::string_view describe_kind(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Null:
      return "nothing";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Map:
      return "a map";
    default:
      return "a value";
  }
}

// Numbers are parsed here rather than with yaml-cpp's as<double>() so that
// the same text always gives the same double (round-trip) and ".nan" or
// "1.5x" are reported rather than accepted.
double to_number(const Context& context, std::string_view key, const YAML::Node& node) {
  if (!node.IsScalar()) {
    context.fail_key(key, fmt::format("expected a number, found {}", describe_kind(node)));
  }
  const auto parsed = parse_number(node.Scalar());
  if (const auto* error = std::get_if<std::string>(&parsed)) context.fail_key(key, *error);
  return std::get<double>(parsed);
}

Eigen::Vector2d to_pair(const Context& context, std::string_view key, const YAML::Node& node,
                        std::string_view form) {
  if (!node.IsSequence()) {
    context.fail_key(key, fmt::format("expected {}, found {}", form, describe_kind(node)));
  }
  if (node.size() != 2) {
    context.fail_key(key, fmt::format("expected {}, found {} elements", form, node.size()));
  }
  return {to_number(context, key, node[0]), to_number(context, key, node[1])};
}

bool to_bool(const Context& context, std::string_view key, const YAML::Node& node) {
  if (!node.IsScalar()) {
    context.fail_key(key, fmt::format("expected true or false, found {}", describe_kind(node)));
  }
  // YAML 1.2 core schema only: "yes", "on" and friends are not booleans.
  const std::string& text = node.Scalar();
  if (text == "true" || text == "True" || text == "TRUE") return true;
  if (text == "false" || text == "False" || text == "FALSE") return false;
  context.fail_key(key, fmt::format("'{}' is not true or false", text));
}

// Names are matched against the sensor column of mice.csv, which has no
// quoting and trims spaces: a name with a comma, a space or a control
// character could never match a row.
bool is_valid_name(std::string_view name) {
  if (name.empty()) return false;
  return std::none_of(name.begin(), name.end(), [](char c) {
    const auto u = static_cast<unsigned char>(c);
    return c == ',' || c == ' ' || u < 0x20 || u == 0x7f;
  });
}

std::string to_name(const Context& context, const YAML::Node& node) {
  if (!node.IsScalar()) {
    context.fail_key("name", fmt::format("expected a name, found {}", describe_kind(node)));
  }
  const std::string& name = node.Scalar();
  if (!is_valid_name(name)) {
    context.fail_key("name", fmt::format("invalid name '{}' (empty, or a comma, space or control "
                                         "character: it could not appear in mice.csv)",
                                         name));
  }
  return name;
}

// The keys of a map, each once, all of them known; anything else is an error.
std::map<std::string, YAML::Node, std::less<>> known_keys(
    const Context& context, const YAML::Node& map, std::span<const std::string_view> allowed) {
  std::map<std::string, YAML::Node, std::less<>> keys;
  for (const auto& entry : map) {
    if (!entry.first.IsScalar()) context.fail("a key is not a plain name");
    const std::string& key = entry.first.Scalar();
    if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
      context.fail(fmt::format("unknown key '{}'", key));
    }
    if (!keys.emplace(key, entry.second).second)
      context.fail(fmt::format("duplicate key '{}'", key));
  }
  return keys;
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

SensorMount parse_sensor(const YAML::Node& node, std::size_t index, std::string_view source,
                         std::string& name) {
  const Context unnamed(source, sensor_label(index, {}));
  if (!node.IsMap()) unnamed.fail(fmt::format("expected a map, found {}", describe_kind(node)));
  // The name first, so that every later message can say which sensor it is.
  for (const auto& entry : node) {
    if (entry.first.IsScalar() && entry.first.Scalar() == "name") {
      name = to_name(unnamed, entry.second);
      break;
    }
  }
  if (name.empty()) unnamed.fail("missing key 'name'");
  const Context context(source, sensor_label(index, name));
  const auto keys = known_keys(context, node, kSensorKeys);
  for (const auto key : kRequiredSensorKeys) {
    if (!keys.contains(key)) context.fail(fmt::format("missing key '{}'", key));
  }

  SensorMount m;
  m.position = to_pair(context, "position", keys.find("position")->second, "[x, y]");
  m.yaw = to_number(context, "yaw", keys.find("yaw")->second);
  m.cpi = to_number(context, "cpi", keys.find("cpi")->second);
  if (auto it = keys.find("scale"); it != keys.end()) {
    m.scale = to_pair(context, "scale", it->second, "[sx, sy]");
  }
  if (auto it = keys.find("mirrored"); it != keys.end()) {
    m.mirrored = to_bool(context, "mirrored", it->second);
  }
  if (auto it = keys.find("max_speed"); it != keys.end()) {
    m.max_speed = to_number(context, "max_speed", it->second);
  }
  if (auto it = keys.find("noise"); it != keys.end()) {
    m.noise = to_number(context, "noise", it->second);
  }
  check_mount(context, m);
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

// `limits: {accel: m/s^2, angular_accel: rad/s^2}`, each optional.
MotionLimits parse_limits(const Context& context, const YAML::Node& node) {
  if (!node.IsMap()) {
    context.fail_key("limits", fmt::format("expected a map, found {}", describe_kind(node)));
  }
  const Context inner(context.source(), "limits");
  const auto keys = known_keys(inner, node, kLimitKeys);
  MotionLimits limits;
  if (auto it = keys.find("accel"); it != keys.end())
    limits.accel = to_number(inner, "accel", it->second);
  if (auto it = keys.find("angular_accel"); it != keys.end())
    limits.angular_accel = to_number(inner, "angular_accel", it->second);
  if (const char* e = limits.validate(); *e) context.fail(e);
  return limits;
}

}  // namespace

std::optional<int> RobotConfig::index_of(std::string_view name) const {
  const auto it = std::find(names.begin(), names.end(), name);
  if (it == names.end()) return std::nullopt;
  return static_cast<int>(it - names.begin());
}

RobotConfig parse_config(std::string_view yaml, std::string_view source) {
  const Context context(source, {});
  std::vector<YAML::Node> documents;
  try {
    documents = YAML::LoadAll(std::string(yaml));
  } catch (const YAML::Exception& e) {
    if (e.mark.is_null()) context.fail(fmt::format("invalid YAML: {}", e.msg));
    throw Error(printable(fmt::format("{}:{}: invalid YAML: {}", source, e.mark.line + 1, e.msg)));
  }
  if (documents.empty() || documents.front().IsNull()) {
    context.fail("empty config (expected keys 'version' and 'sensors')");
  }
  if (documents.size() > 1) {
    context.fail(fmt::format("expected one YAML document, found {}", documents.size()));
  }
  const YAML::Node& root = documents.front();
  if (!root.IsMap()) context.fail(fmt::format("expected a map, found {}", describe_kind(root)));

  // The version before anything else: a newer file may well have keys this
  // reader does not know, and "unsupported version" is the useful message.
  std::optional<YAML::Node> found_version;
  for (const auto& entry : root) {
    if (entry.first.IsScalar() && entry.first.Scalar() == "version") found_version = entry.second;
  }
  if (!found_version) context.fail("missing key 'version'");
  const YAML::Node& version_node = *found_version;
  if (!version_node.IsScalar()) {
    context.fail_key("version",
                     fmt::format("expected an integer, found {}", describe_kind(version_node)));
  }
  const std::string& version_text = version_node.Scalar();
  int version = 0;
  const auto [end, ec] =
      std::from_chars(version_text.data(), version_text.data() + version_text.size(), version);
  if (ec != std::errc{} || end != version_text.data() + version_text.size()) {
    context.fail_key("version", fmt::format("'{}' is not an integer", version_text));
  }
  if (version != kConfigVersion) {
    context.fail(fmt::format("version {} is not supported (expected {})", version, kConfigVersion));
  }

  const auto keys = known_keys(context, root, kTopKeys);
  const auto sensors = keys.find("sensors");
  if (sensors == keys.end()) context.fail("missing key 'sensors'");
  if (!sensors->second.IsSequence()) {
    context.fail_key("sensors", fmt::format("expected a list of sensors, found {}",
                                            describe_kind(sensors->second)));
  }
  check_count(context, sensors->second.size());

  RobotConfig config;
  std::vector<SensorMount> mounts;
  for (std::size_t i = 0; i < sensors->second.size(); ++i) {
    std::string name;
    mounts.push_back(parse_sensor(sensors->second[i], i, source, name));
    if (config.index_of(name)) context.fail(fmt::format("duplicate sensor name '{}'", name));
    config.names.push_back(std::move(name));
  }
  config.array = SensorArray(std::move(mounts));
  if (const auto limits = keys.find("limits"); limits != keys.end()) {
    config.limits = parse_limits(context, limits->second);
  }
  return config;
}

RobotConfig read_config(const std::filesystem::path& path) {
  const std::string source = path.string();
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw Error(fmt::format("{}: cannot open (is a directory)", source));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("{}: cannot open", source));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw Error(fmt::format("{}: read error", source));
  return parse_config(text.str(), source);
}

std::string format_config(const RobotConfig& config) {
  const Context context("config", {});
  const std::size_t n = config.array.mounts().size();
  if (config.names.size() != n) {
    context.fail(fmt::format("{} names for {} sensors", config.names.size(), n));
  }
  check_count(context, n);

  // "{}" is fmt's shortest representation that reads back as the same double.
  std::string out = fmt::format("version: {}\nsensors:\n", kConfigVersion);
  for (std::size_t i = 0; i < n; ++i) {
    const std::string& name = config.names[i];
    const SensorMount& m = config.array.mounts()[i];
    const Context sensor(context.source(), sensor_label(i, is_valid_name(name) ? name : ""));
    if (!is_valid_name(name)) sensor.fail_key("name", fmt::format("invalid name '{}'", name));
    if (config.index_of(name) != static_cast<int>(i)) {
      context.fail(fmt::format("duplicate sensor name '{}'", name));
    }
    check_mount(sensor, m);
    out += fmt::format("  - name: {}\n", yaml_name(name));
    out += fmt::format("    position: [{}, {}]\n", m.position.x(), m.position.y());
    out += fmt::format("    yaw: {}\n", m.yaw);
    out += fmt::format("    cpi: {}\n", m.cpi);
    out += fmt::format("    scale: [{}, {}]\n", m.scale.x(), m.scale.y());
    out += fmt::format("    mirrored: {}\n", m.mirrored);
    if (m.max_speed) out += fmt::format("    max_speed: {}\n", *m.max_speed);
    if (m.noise) out += fmt::format("    noise: {}\n", *m.noise);
  }
  if (config.limits) {
    if (const char* e = config.limits->validate(); *e) context.fail(e);
    out += fmt::format("limits:\n  accel: {}\n  angular_accel: {}\n", config.limits->accel,
                       config.limits->angular_accel);
  }
  return out;
}

void write_config(const RobotConfig& config, const std::filesystem::path& path) {
  std::string text = format_config(config);
  AtomicFile file(path);
  file.stream() << text;
  file.commit();
}

}  // namespace moa::io
