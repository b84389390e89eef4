// Robot config v1 (docs/formats/config.md): parsing, every rejection with its exact
// message, and exact round-trip through format_config.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "support/error_of.hpp"

namespace moa::io {
namespace {

using test::error_of;

std::string parse_error(const std::string& yaml) {
  return error_of([&] { parse_config(yaml, "robot.yaml"); });
}

// A fresh directory, removed with everything in it at the end of the test.
class TempDir {
 public:
  TempDir() {
    std::random_device random;
    path_ = std::filesystem::temp_directory_path() /
            ("moa-test-config-" + std::to_string(random()) + std::to_string(random()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// Two sensors; `first` and `second` are spliced into their maps.
std::string two_sensors(const std::string& first = "", const std::string& second = "") {
  return "version: 1\n"
         "sensors:\n"
         "  - name: m1\n"
         "    position: [0.1, 0.0]\n"
         "    yaw: 0\n"
         "    cpi: 800\n" +
         first +
         "  - name: m2\n"
         "    position: [-0.1, 0.0]\n"
         "    yaw: 3.141592653589793\n"
         "    cpi: 800\n" +
         second;
}

// A config whose second sensor lacks the key `missing`.
std::string without_key(const std::string& missing) {
  const std::vector<std::pair<std::string, std::string>> keys{
      {"name", "m2"}, {"position", "[0, 1]"}, {"yaw", "0"}, {"cpi", "800"}};
  std::string text =
      "version: 1\nsensors:\n  - {name: m1, position: [0, 0], yaw: 0, cpi: 800}\n  -";
  const char* indent = " ";
  for (const auto& [key, value] : keys) {
    if (key == missing) continue;
    text += indent + key + ": " + value + "\n";
    indent = "    ";
  }
  return text;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }
// The same number, -0 and 0 taken as one (the config is written without "-0").
bool same_value(double a, double b) { return same_bits(a + 0.0, b + 0.0); }

void expect_identical(const RobotConfig& a, const RobotConfig& b) {
  ASSERT_EQ(a.names, b.names);
  ASSERT_EQ(a.array.size(), b.array.size());
  for (int i = 0; i < a.array.size(); ++i) {
    const SensorMount& x = a.array[i];
    const SensorMount& y = b.array[i];
    SCOPED_TRACE("sensor " + a.names[static_cast<std::size_t>(i)]);
    EXPECT_TRUE(same_value(x.position.x(), y.position.x()));
    EXPECT_TRUE(same_value(x.position.y(), y.position.y()));
    EXPECT_TRUE(same_value(x.yaw, y.yaw));
    EXPECT_TRUE(same_bits(x.cpi, y.cpi));
    EXPECT_TRUE(same_bits(x.scale.x(), y.scale.x()));
    EXPECT_TRUE(same_bits(x.scale.y(), y.scale.y()));
    EXPECT_EQ(x.mirrored, y.mirrored);
    ASSERT_EQ(x.max_speed.has_value(), y.max_speed.has_value());
    if (x.max_speed) {
      EXPECT_TRUE(same_bits(*x.max_speed, *y.max_speed));
    }
    ASSERT_EQ(x.noise.has_value(), y.noise.has_value());
    if (x.noise) {
      EXPECT_TRUE(same_bits(*x.noise, *y.noise));
    }
    EXPECT_TRUE(same_value(x.latency, y.latency));
    ASSERT_EQ(x.speed_scale.active(), y.speed_scale.active());
    ASSERT_EQ(x.speed_scale.size(), y.speed_scale.size());
    for (int k = 0; k < x.speed_scale.size(); ++k) {
      EXPECT_TRUE(same_bits(x.speed_scale.speed(k), y.speed_scale.speed(k)));
      EXPECT_TRUE(same_bits(x.speed_scale.ratio_at(k), y.speed_scale.ratio_at(k)));
    }
  }
  EXPECT_EQ(a.camera_latency, b.camera_latency);
  EXPECT_EQ(a.wheels_latency, b.wheels_latency);
}

// A double from anywhere in [lo, hi) with random low-order bits, so that
// the round-trip test sees numbers needing all 17 significant digits.
double random_double(std::mt19937_64& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

RobotConfig random_config(std::mt19937_64& rng) {
  // Valid names (docs/formats/config.md) that YAML would read as something
  // else unquoted: null, a boolean, a number, a list item.
  static const char* const kNames[] = {"m1", "left", "null", "true", "-x",  "1e5",   "s.2",
                                       "_",  "0",    "No",   ".5",   "A-B", "y.a_b", "-"};
  RobotConfig config;
  std::vector<SensorMount> mounts;
  const int n = 1 + static_cast<int>(rng() % kMaxSensors);
  std::vector<std::string> pool(std::begin(kNames), std::end(kNames));
  std::shuffle(pool.begin(), pool.end(), rng);
  for (int i = 0; i < n; ++i) {
    SensorMount m;
    const double magnitude = std::pow(10.0, random_double(rng, -12.0, 12.0));
    m.position = {random_double(rng, -1.0, 1.0) * magnitude, random_double(rng, -0.3, 0.3)};
    m.yaw = rng() % 8 == 0 ? -0.0 : random_double(rng, -10.0, 10.0);
    m.cpi = rng() % 2 == 0 ? 800.0 : random_double(rng, 1e-3, 1e5);
    m.scale = {random_double(rng, 0.5, 1.5), std::pow(10.0, random_double(rng, -300.0, 300.0))};
    m.mirrored = rng() % 2 == 0;
    if (rng() % 2 == 0) m.max_speed = random_double(rng, 1e-6, 10.0);
    if (rng() % 3 == 0) m.noise = rng() % 4 == 0 ? 0.0 : random_double(rng, 0.0, 0.1);
    if (rng() % 2 == 0) m.latency = random_double(rng, -1.0, 1.0);
    if (rng() % 3 == 0) {
      // A usable table: 2..8 knots, increasing speeds, ratios near 1 (a
      // drawn table that s ratio(s) would not invert is drawn again).
      do {
        const int knots = 2 + static_cast<int>(rng() % 7);
        std::array<double, SpeedScale::kMaxKnots> s{}, r{};
        double speed = random_double(rng, 0.0, 0.5);
        for (int k = 0; k < knots; ++k) {
          s[static_cast<std::size_t>(k)] = speed;
          r[static_cast<std::size_t>(k)] = random_double(rng, 0.8, 1.2);
          speed += random_double(rng, 0.1, 1.0);
        }
        m.speed_scale = SpeedScale(s.data(), r.data(), knots, knots);
      } while (!m.speed_scale.active());
    }
    mounts.push_back(m);
    config.names.push_back(static_cast<std::size_t>(i) < pool.size()
                               ? pool[static_cast<std::size_t>(i)]
                               : "s" + std::to_string(i));
  }
  config.array = SensorArray(std::move(mounts));
  if (rng() % 2 == 0) config.camera_latency = random_double(rng, -60.0, 60.0);
  if (rng() % 3 == 0) config.wheels_latency = rng() % 4 == 0 ? 0.0 : random_double(rng, -1.0, 1.0);
  return config;
}

// ------------------------------------------------------------------ parsing

TEST(Config, ParsesEveryKey) {
  const RobotConfig c = parse_config(
      "version: 1\n"
      "sensors:\n"
      "  - name: m1              # unique, used by mice.csv\n"
      "    position: [0.07071, -0.07071]\n"
      "    yaw: 0.785398\n"
      "    cpi: 800\n"
      "    scale: [1.01, 0.99]\n"
      "    mirrored: true\n"
      "    max_speed: 0.3556\n"
      "    noise: 0.002\n",
      "robot.yaml");
  ASSERT_EQ(c.names, std::vector<std::string>{"m1"});
  ASSERT_EQ(c.array.size(), 1);
  const SensorMount& m = c.array[0];
  EXPECT_EQ(m.position.x(), 0.07071);
  EXPECT_EQ(m.position.y(), -0.07071);
  EXPECT_EQ(m.yaw, 0.785398);
  EXPECT_EQ(m.cpi, 800.0);
  EXPECT_EQ(m.scale.x(), 1.01);
  EXPECT_EQ(m.scale.y(), 0.99);
  EXPECT_TRUE(m.mirrored);
  EXPECT_EQ(m.max_speed, 0.3556);
  EXPECT_EQ(m.noise, 0.002);
}

TEST(Config, OptionalKeysTakeTheirDefaults) {
  const RobotConfig c = parse_config(two_sensors(), "robot.yaml");
  ASSERT_EQ(c.array.size(), 2);
  const SensorMount& m = c.array[1];
  EXPECT_EQ(m.scale, Eigen::Vector2d(1.0, 1.0));
  EXPECT_FALSE(m.mirrored);
  EXPECT_FALSE(m.max_speed);
  EXPECT_FALSE(m.noise);
}

TEST(Config, KeepsSensorOrderAndFindsIndexByName) {
  const RobotConfig c = parse_config(two_sensors(), "robot.yaml");
  EXPECT_EQ(c.names, (std::vector<std::string>{"m1", "m2"}));
  EXPECT_EQ(c.index_of("m1"), 0);
  EXPECT_EQ(c.index_of("m2"), 1);
  EXPECT_EQ(c.index_of("m3"), std::nullopt);
  EXPECT_EQ(c.array[1].position.x(), -0.1);
}

TEST(Config, NoiseOfZeroIsAccepted) {
  EXPECT_EQ(parse_config(two_sensors("    noise: 0\n"), "robot.yaml").array[0].noise, 0.0);
}

TEST(Config, LimitsAreOptionalAndRead) {
  EXPECT_FALSE(parse_config(two_sensors(), "robot.yaml").limits);
  const RobotConfig c =
      parse_config(two_sensors() + "limits:\n  accel: 1.5\n  angular_accel: 12\n", "robot.yaml");
  ASSERT_TRUE(c.limits);
  EXPECT_EQ(c.limits->accel, 1.5);
  EXPECT_EQ(c.limits->angular_accel, 12.0);
  // A key left out takes RobotLimits' default.
  const RobotConfig half = parse_config(two_sensors() + "limits: {accel: 3}\n", "robot.yaml");
  EXPECT_EQ(half.limits->angular_accel, RobotLimits{}.angular_accel);
  // Written back exactly.
  const RobotConfig back = parse_config(format_config(c), "robot.yaml");
  ASSERT_TRUE(back.limits);
  EXPECT_EQ(back.limits->accel, 1.5);
  EXPECT_EQ(back.limits->angular_accel, 12.0);
}

TEST(Config, LatenciesAreOptionalAndRead) {
  const RobotConfig none = parse_config(two_sensors(), "robot.yaml");
  EXPECT_EQ(none.array[0].latency, 0.0);
  EXPECT_FALSE(none.camera_latency);
  EXPECT_FALSE(none.wheels_latency);
  const RobotConfig c = parse_config(
      two_sensors("    latency: 0.004\n") + "camera:\n  latency: 0.06\nwheels: {latency: -0.002}\n",
      "robot.yaml");
  EXPECT_EQ(c.array[0].latency, 0.004);
  EXPECT_EQ(c.array[1].latency, 0.0);
  EXPECT_EQ(c.camera_latency, 0.06);
  EXPECT_EQ(c.wheels_latency, -0.002);
}

TEST(Config, SpeedScaleIsOptionalReadAndWrittenBack) {
  EXPECT_FALSE(parse_config(two_sensors(), "robot.yaml").array[0].speed_scale.active());
  const RobotConfig c = parse_config(
      two_sensors("    speed_scale: {speeds: [0.5, 1.5, 2.5], ratios: [1, 0.96, 0.9]}\n"),
      "robot.yaml");
  const SpeedScale& s = c.array[0].speed_scale;
  ASSERT_TRUE(s.active());
  ASSERT_EQ(s.size(), 3);
  EXPECT_EQ(s.speed(2), 2.5);
  EXPECT_EQ(s.ratio_at(1), 0.96);
  EXPECT_FALSE(c.array[1].speed_scale.active());
  const std::string text = format_config(c);
  EXPECT_NE(text.find("    speed_scale:\n      speeds: [0.5, 1.5, 2.5]\n      ratios: [1, 0.96, "
                      "0.9]\n"),
            std::string::npos)
      << text;
  expect_identical(parse_config(text, "robot.yaml"), c);
}

// ---------------------------------------------------------------- rejections

TEST(ConfigErrors, SpeedScaleTablesAreChecked) {
  const auto bad = [](const std::string& table) {
    return parse_error(two_sensors("    speed_scale: " + table + "\n"));
  };
  EXPECT_EQ(
      bad("{speeds: [1], ratios: [0.9]}"),
      "robot.yaml:7: sensor 'm1': key 'speed_scale.speeds': expected 2 to 8 numbers, found 1");
  EXPECT_EQ(
      bad("{speeds: [0, 1, 2, 3, 4, 5, 6, 7, 8], ratios: [1, 1, 1, 1, 1, 1, 1, 1, 1]}"),
      "robot.yaml:7: sensor 'm1': key 'speed_scale.speeds': expected 2 to 8 numbers, found 9");
  EXPECT_EQ(bad("{speeds: [0, 1, 2], ratios: [1, 0.9]}"),
            "robot.yaml:7: sensor 'm1': key 'speed_scale.ratios': expected one ratio per speed "
            "(3), found 2");
  EXPECT_EQ(bad("{speeds: [0, 2, 1], ratios: [1, 0.9, 0.8]}"),
            "robot.yaml:7: sensor 'm1': key 'speed_scale': speeds[2]: must be > speeds[1] (found 1 "
            "after 2)");
  EXPECT_EQ(bad("{speeds: [-1, 2], ratios: [1, 0.9]}"),
            "robot.yaml:7: sensor 'm1': key 'speed_scale': speeds[0]: must be a finite number >= 0 "
            "(found -1)");
  EXPECT_EQ(bad("{speeds: [0, 2], ratios: [1, 1.6]}"),
            "robot.yaml:7: sensor 'm1': key 'speed_scale': ratios[1]: must be within [0.5, 1.5] "
            "(found 1.6)");
  // s ratio(s) = s (1.5 - 0.5 s) on [1, 2] has f'(2) = 1.5 - 2 = -0.5: not invertible.
  EXPECT_EQ(bad("{speeds: [1, 2], ratios: [1.0, 0.5]}"),
            "robot.yaml:7: sensor 'm1': key 'speed_scale': between speeds[0] and speeds[1]: speed "
            "* ratio(speed) must increase with speed (the counts could not be inverted) (ratio "
            "falls from 1 to 0.5 over 1..2 m/s)");
  EXPECT_EQ(bad("{speeds: [0, 1]}"), "robot.yaml:7: sensor 'm1': missing key 'speed_scale.ratios'");
  EXPECT_EQ(bad("{speeds: [0, 1], ratios: [1, 1], knots: 2}"),
            "robot.yaml:7: sensor 'm1': unknown key 'speed_scale.knots' (known here: speeds, "
            "ratios)");
  // format_config refuses what parse_config would.
  RobotConfig c = parse_config(two_sensors(), "robot.yaml");
  const std::array<real, 2> speeds{0.0, 1.0}, ratios{1.0, 2.0};
  c.array[1].speed_scale = SpeedScale(speeds.data(), ratios.data(), 2, 2);
  EXPECT_EQ(error_of([&] { (void)format_config(c); }),
            "config: sensor 'm2': key 'speed_scale': ratios[1]: must be within [0.5, 1.5] (found "
            "2)");
}

TEST(ConfigErrors, LatenciesAreBoundedAndFinite) {
  EXPECT_EQ(parse_error(two_sensors("    latency: 1.5\n")),
            "robot.yaml:7: sensor 'm1': key 'latency': must be within [-1, 1] (found 1.5)");
  EXPECT_EQ(parse_error(two_sensors("", "    latency: .nan\n")),
            "robot.yaml:11: sensor 'm2': key 'latency': '.nan' is not a finite number");
  EXPECT_EQ(parse_error(two_sensors() + "camera: {latency: 61}\n"),
            "robot.yaml:11: key 'camera.latency': must be within [-60, 60] (found 61)");
  EXPECT_EQ(parse_error(two_sensors() + "wheels: {delay: 1}\n"),
            "robot.yaml:11: unknown key 'wheels.delay' (known here: latency)");
}

TEST(ConfigErrors, LimitsMustBePositiveAndFinite) {
  EXPECT_EQ(parse_error(two_sensors() + "limits: {accel: .nan}\n"),
            "robot.yaml:11: key 'limits.accel': '.nan' is not a finite number");
  EXPECT_EQ(parse_error(two_sensors() + "limits: {angular_accel: 0}\n"),
            "robot.yaml:11: key 'limits.angular_accel': must be > 0 (found 0)");
  EXPECT_EQ(parse_error(two_sensors() + "limits: {jerk: 1}\n"),
            "robot.yaml:11: unknown key 'limits.jerk' (known here: accel, angular_accel)");
  EXPECT_EQ(parse_error(two_sensors() + "limits: 2\n"),
            "robot.yaml:11: key 'limits': expected a map, found '2'");
}

TEST(ConfigErrors, MissingRequiredKeyNamesKeyAndSensor) {
  EXPECT_EQ(parse_error(without_key("position")),
            "robot.yaml:4: sensor 'm2': missing key 'position'");
  EXPECT_EQ(parse_error(without_key("yaw")), "robot.yaml:4: sensor 'm2': missing key 'yaw'");
  EXPECT_EQ(parse_error(without_key("cpi")), "robot.yaml:4: sensor 'm2': missing key 'cpi'");
}

TEST(ConfigErrors, MissingNameNamesSensorByPosition) {
  EXPECT_EQ(parse_error(without_key("name")), "robot.yaml:4: sensor 2: missing key 'name'");
}

TEST(ConfigErrors, UnknownSensorKeyIsRejected) {
  EXPECT_EQ(parse_error(two_sensors("", "    cip: 800\n")),
            "robot.yaml:11: sensor 'm2': unknown key 'cip' (known here: name, position, yaw, cpi, "
            "scale, mirrored, max_speed, noise, latency, speed_scale)");
}

TEST(ConfigErrors, UnknownTopLevelKeyIsRejected) {
  EXPECT_EQ(parse_error(two_sensors() + "sensorz: []\n"),
            "robot.yaml:11: unknown key 'sensorz' (known here: version, sensors, limits, imu, "
            "camera, wheels)");
}

TEST(ConfigErrors, DuplicateKeyIsRejected) {
  EXPECT_EQ(parse_error(two_sensors("    cpi: 400\n")),
            "robot.yaml:7: sensor 'm1': duplicate key 'cpi'");
}

TEST(ConfigErrors, DuplicateSensorNameIsRejected) {
  const std::string text =
      "version: 1\n"
      "sensors:\n"
      "  - {name: m1, position: [0, 0], yaw: 0, cpi: 800}\n"
      "  - {name: m1, position: [1, 0], yaw: 0, cpi: 800}\n";
  EXPECT_EQ(parse_error(text), "robot.yaml:4: duplicate sensor name 'm1'");
}

TEST(ConfigErrors, UnsupportedVersionIsRejected) {
  std::string text = two_sensors();
  text.replace(0, std::strlen("version: 1"), "version: 2");
  EXPECT_EQ(parse_error(text), "robot.yaml:1: version 2 is not supported (expected 1)");
}

TEST(ConfigErrors, VersionIsCheckedBeforeUnknownKeys) {
  EXPECT_EQ(parse_error("version: 3\nrobot: {}\n"),
            "robot.yaml:1: version 3 is not supported (expected 1)");
}

TEST(ConfigErrors, MissingVersionIsRejected) {
  EXPECT_EQ(parse_error(two_sensors().substr(std::strlen("version: 1\n"))),
            "robot.yaml:1: missing key 'version'");
}

TEST(ConfigErrors, NonIntegerVersionIsRejected) {
  EXPECT_EQ(parse_error("version: 1.0\nsensors: []\n"),
            "robot.yaml:1: version 1.0 is not supported (expected 1)");
}

TEST(ConfigErrors, MissingSensorsIsRejected) {
  EXPECT_EQ(parse_error("version: 1\n"), "robot.yaml:1: missing key 'sensors'");
}

TEST(ConfigErrors, EmptySensorListIsRejected) {
  EXPECT_EQ(parse_error("version: 1\nsensors: []\n"),
            "robot.yaml: no sensors (key 'sensors' is an empty list)");
}

TEST(ConfigErrors, SensorsThatAreNotAListAreRejected) {
  EXPECT_EQ(parse_error("version: 1\nsensors: {m1: 1}\n"),
            "robot.yaml:2: key 'sensors': expected a list of sensors, found a map");
}

TEST(ConfigErrors, SensorThatIsNotAMapIsRejected) {
  EXPECT_EQ(parse_error("version: 1\nsensors: [m1]\n"),
            "robot.yaml:2: sensor 1: expected a map, found 'm1'");
}

TEST(ConfigErrors, MoreThanMaxSensorsAreRejected) {
  std::string text = "version: 1\nsensors:\n";
  for (int i = 0; i <= kMaxSensors; ++i) {
    text += "  - {name: s" + std::to_string(i) + ", position: [0, 0], yaw: 0, cpi: 800}\n";
  }
  EXPECT_EQ(parse_error(text), "robot.yaml: 17 sensors, at most 16 are supported");
}

TEST(ConfigErrors, YamlSyntaxErrorCarriesLine) {
  const std::string message = parse_error("version: 1\nsensors:\n  - name: [m1\n    yaw: 0\n");
  EXPECT_EQ(message.rfind("robot.yaml:", 0), 0u) << message;
  EXPECT_NE(message.find("invalid YAML"), std::string::npos) << message;
  // yaml-cpp reports the position where it gave up: within the broken list.
  EXPECT_TRUE(message.starts_with("robot.yaml:3:") || message.starts_with("robot.yaml:4:") ||
              message.starts_with("robot.yaml:5:"))
      << message;
}

TEST(ConfigErrors, TabIndentationIsASyntaxErrorWithLine) {
  const std::string message = parse_error("version: 1\nsensors:\n\t- name: m1\n");
  EXPECT_TRUE(message.starts_with("robot.yaml:3: invalid YAML: ")) << message;
}

TEST(ConfigErrors, EmptyDocumentIsRejected) {
  EXPECT_EQ(parse_error(""), "robot.yaml: empty config (expected keys 'version' and 'sensors')");
  EXPECT_EQ(parse_error("# nothing\n"),
            "robot.yaml: empty config (expected keys 'version' and 'sensors')");
}

TEST(ConfigErrors, SecondDocumentIsRejected) {
  EXPECT_EQ(parse_error(two_sensors() + "---\nversion: 1\n"),
            "robot.yaml:11: expected one YAML document, found another");
}

TEST(ConfigErrors, TopLevelThatIsNotAMapIsRejected) {
  EXPECT_EQ(parse_error("- 1\n- 2\n"), "robot.yaml:1: expected a map, found a list");
}

TEST(ConfigErrors, WrongTypesAreRejected) {
  EXPECT_EQ(parse_error(two_sensors("", "    scale: 1\n")),
            "robot.yaml:11: sensor 'm2': key 'scale': expected a list of numbers, found '1'");
  EXPECT_EQ(parse_error(two_sensors("", "    scale: [1, 1, 1]\n")),
            "robot.yaml:11: sensor 'm2': key 'scale': expected 2 numbers, found 3");
  EXPECT_EQ(parse_error(two_sensors("", "    mirrored: yes\n")),
            "robot.yaml:11: sensor 'm2': key 'mirrored': expected true or false, found 'yes'");
  EXPECT_EQ(parse_error(two_sensors("", "    max_speed: fast\n")),
            "robot.yaml:11: sensor 'm2': key 'max_speed': 'fast' is not a number");
  EXPECT_EQ(parse_error(two_sensors("", "    noise:\n")),
            "robot.yaml:12: sensor 'm2': key 'noise': expected a number, found nothing");
  EXPECT_EQ(
      parse_error("version: 1\nsensors:\n  - {name: [m1], position: [0, 0], yaw: 0, cpi: 1}\n"),
      "robot.yaml:3: sensor 1: key 'name': expected a name, found a list");
}

TEST(ConfigErrors, PositionMustHaveTwoNumbers) {
  const std::string base = "version: 1\nsensors:\n  - {name: m1, yaw: 0, cpi: 800, position: ";
  EXPECT_EQ(parse_error(base + "[0.1]}\n"),
            "robot.yaml:3: sensor 'm1': key 'position': expected 2 numbers, found 1");
  EXPECT_EQ(parse_error(base + "[0.1, 0, 0]}\n"),
            "robot.yaml:3: sensor 'm1': key 'position': expected 2 numbers, found 3");
  EXPECT_EQ(parse_error(base + "{x: 1}}\n"),
            "robot.yaml:3: sensor 'm1': key 'position': expected a list of numbers, found a map");
  EXPECT_EQ(parse_error(base + "[0.1, abc]}\n"),
            "robot.yaml:3: sensor 'm1': key 'position': 'abc' is not a number");
}

TEST(ConfigErrors, TrailingGarbageInANumberIsRejected) {
  EXPECT_EQ(
      parse_error("version: 1\nsensors:\n  - {name: m1, position: [0, 0], yaw: 1.5x, cpi: 8}\n"),
      "robot.yaml:3: sensor 'm1': key 'yaw': '1.5x' is not a number");
}

TEST(ConfigErrors, NonFiniteNumbersAreRejected) {
  const std::string head = "version: 1\nsensors:\n  - {name: m1, ";
  EXPECT_EQ(parse_error(head + "position: [.nan, 0], yaw: 0, cpi: 800}\n"),
            "robot.yaml:3: sensor 'm1': key 'position': '.nan' is not a finite number");
  EXPECT_EQ(parse_error(head + "position: [0, 0], yaw: .inf, cpi: 800}\n"),
            "robot.yaml:3: sensor 'm1': key 'yaw': '.inf' is not a finite number");
  EXPECT_EQ(parse_error(head + "position: [0, 0], yaw: 0, cpi: -.Inf}\n"),
            "robot.yaml:3: sensor 'm1': key 'cpi': '-.Inf' is not a finite number");
  EXPECT_EQ(parse_error(head + "position: [0, 0], yaw: nan, cpi: 800}\n"),
            "robot.yaml:3: sensor 'm1': key 'yaw': 'nan' is not a finite number");
  EXPECT_EQ(parse_error(head + "position: [0, 0], yaw: 0, cpi: 800, max_speed: 1e999}\n"),
            "robot.yaml:3: sensor 'm1': key 'max_speed': '1e999' is out of range");
}

TEST(ConfigErrors, CpiMustBePositive) {
  EXPECT_EQ(parse_error("version: 1\nsensors:\n  - {name: m1, position: [0, 0], yaw: 0, cpi: 0}\n"),
            "robot.yaml:3: sensor 'm1': key 'cpi': must be > 0 (found 0)");
  EXPECT_EQ(
      parse_error("version: 1\nsensors:\n  - {name: m1, position: [0, 0], yaw: 0, cpi: -800}\n"),
      "robot.yaml:3: sensor 'm1': key 'cpi': must be > 0 (found -800)");
}

TEST(ConfigErrors, ScaleMustBePositive) {
  EXPECT_EQ(parse_error(two_sensors("    scale: [1, 0]\n")),
            "robot.yaml:7: sensor 'm1': key 'scale': must be > 0 (found [1, 0])");
  EXPECT_EQ(parse_error(two_sensors("    scale: [-1, 1]\n")),
            "robot.yaml:7: sensor 'm1': key 'scale': must be > 0 (found [-1, 1])");
}

TEST(ConfigErrors, MaxSpeedMustBePositive) {
  EXPECT_EQ(parse_error(two_sensors("    max_speed: 0\n")),
            "robot.yaml:7: sensor 'm1': key 'max_speed': must be > 0 (found 0)");
}

TEST(ConfigErrors, NoiseMustNotBeNegative) {
  EXPECT_EQ(parse_error(two_sensors("", "    noise: -0.001\n")),
            "robot.yaml:11: sensor 'm2': key 'noise': must be >= 0 (found -0.001)");
}

TEST(ConfigErrors, NameThatCannotAppearInMiceCsvIsRejected) {
  const std::string message = parse_error(
      "version: 1\nsensors:\n  - {name: left mouse, position: [0, 0], yaw: 0, cpi: 1}\n");
  EXPECT_TRUE(message.starts_with("robot.yaml:3: sensor 1: key 'name': invalid name 'left mouse'"))
      << message;
  EXPECT_TRUE(
      parse_error("version: 1\nsensors:\n  - {name: 'a,b', position: [0, 0], yaw: 0, cpi: 1}\n")
          .starts_with("robot.yaml:3: sensor 1: key 'name': invalid name 'a,b'"));
}

// ----------------------------------------------------------------- files

TEST(ConfigFile, MissingFileCannotBeOpened) {
  const TempDir dir;
  const auto path = dir.path() / "absent.yaml";
  EXPECT_EQ(error_of([&] { read_config(path); }), path.string() + ": cannot open");
}

TEST(ConfigFile, ErrorsNameTheFile) {
  const TempDir dir;
  const auto path = dir.path() / "robot.yaml";
  std::ofstream(path) << two_sensors("", "    cip: 800\n");
  EXPECT_EQ(error_of([&] { read_config(path); }),
            path.string() +
                ":11: sensor 'm2': unknown key 'cip' (known here: name, position, yaw, cpi, scale, "
                "mirrored, max_speed, noise, latency, speed_scale)");
}

TEST(ConfigFile, WriteThenReadReproducesConfig) {
  const TempDir dir;
  const auto path = dir.path() / "robot.yaml";
  const RobotConfig original = parse_config(two_sensors("    max_speed: 0.3556\n"), "robot.yaml");
  write_config(original, path);
  expect_identical(read_config(path), original);
  // Only the target is left: the temporary file was renamed onto it.
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()),
                          std::filesystem::directory_iterator()),
            1);
}

// -------------------------------------------------------------- formatting

TEST(ConfigFormat, RoundTripsRandomConfigsExactly) {
  std::mt19937_64 rng(20240611);
  for (int trial = 0; trial < 300; ++trial) {
    const RobotConfig original = random_config(rng);
    const std::string text = format_config(original);
    SCOPED_TRACE(text);
    RobotConfig parsed;
    ASSERT_NO_THROW(parsed = parse_config(text, "formatted"));
    expect_identical(parsed, original);
    if (testing::Test::HasFailure()) return;
  }
}

TEST(ConfigFormat, WritesOptionalKeysOnlyWhenSet) {
  const RobotConfig c = parse_config(two_sensors("    noise: 0.002\n"), "robot.yaml");
  EXPECT_EQ(format_config(c),
            "version: 1\n"
            "sensors:\n"
            "  - name: m1\n"
            "    position: [0.1, 0]\n"
            "    yaw: 0\n"
            "    cpi: 800\n"
            "    scale: [1, 1]\n"
            "    mirrored: false\n"
            "    noise: 0.002\n"
            "  - name: m2\n"
            "    position: [-0.1, 0]\n"
            "    yaw: 3.141592653589793\n"
            "    cpi: 800\n"
            "    scale: [1, 1]\n"
            "    mirrored: false\n");
}

TEST(ConfigFormat, NegativeZeroIsWrittenAsZero) {
  RobotConfig c = parse_config(two_sensors(), "robot.yaml");
  c.array[0].position.y() = -0.0;
  c.array[0].yaw = -0.0;
  const std::string text = format_config(c);
  EXPECT_EQ(text.find("-0,"), std::string::npos) << text;
  EXPECT_EQ(text.find("-0]"), std::string::npos) << text;
  EXPECT_EQ(text.find("-0\n"), std::string::npos) << text;
  EXPECT_NE(text.find("    position: [0.1, 0]\n    yaw: 0\n"), std::string::npos) << text;
}

TEST(ConfigErrors, NamesAreLimitedToWhatEveryOutputCarries) {
  for (const std::string& bad :
       std::vector<std::string>{"m+4", "a/b", "x*y", "caf\xc3\xa9", std::string(33, 'a')}) {
    SCOPED_TRACE(bad);
    const std::string message = parse_error("version: 1\nsensors:\n  - {name: '" + bad +
                                            "', position: [0, 0], yaw: 0, cpi: 1}\n");
    EXPECT_NE(message.find("key 'name': invalid name"), std::string::npos) << message;
    EXPECT_NE(message.find("a name is 1 to 32 characters among A-Z a-z 0-9 _ . -"),
              std::string::npos)
        << message;
  }
  for (const std::string& good :
       std::vector<std::string>{"m1", "front-left", "s_2.b", std::string(32, 'z')}) {
    EXPECT_NO_THROW(parse_config(
        "version: 1\nsensors:\n  - {name: " + good + ", position: [0, 0], yaw: 0, cpi: 1}\n",
        "robot.yaml"))
        << good;
  }
}

TEST(ConfigFormat, InvalidConfigIsNotWritten) {
  RobotConfig c = parse_config(two_sensors(), "robot.yaml");
  c.array[1].cpi = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(error_of([&] { format_config(c); }),
            "config: sensor 'm2': key 'cpi': must be > 0 (found nan)");

  c = parse_config(two_sensors(), "robot.yaml");
  c.names[1] = "m1";
  EXPECT_EQ(error_of([&] { format_config(c); }), "config: duplicate sensor name 'm1'");

  c = parse_config(two_sensors(), "robot.yaml");
  c.names.pop_back();
  EXPECT_EQ(error_of([&] { format_config(c); }), "config: 1 names for 2 sensors");

  const TempDir dir;
  EXPECT_THROW(write_config(c, dir.path() / "robot.yaml"), Error);
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

}  // namespace
}  // namespace moa::io

namespace moa::io {
namespace {

TEST(ConfigImu, ReadsWritesAndRefusesTheGyroBlock) {
  const std::string base =
      "version: 1\nsensors:\n  - {name: m1, position: [0.1, 0], yaw: 0, cpi: 800}\n"
      "  - {name: m2, position: [-0.1, 0], yaw: 0, cpi: 800}\n";
  EXPECT_FALSE(parse_config(base, "robot.yaml").imu);
  const RobotConfig c =
      parse_config(base + "imu:\n  scale: 1.02\n  bias: -0.01\n  latency: 0.005\n", "robot.yaml");
  ASSERT_TRUE(c.imu);
  EXPECT_EQ(c.imu->scale, 1.02);
  EXPECT_EQ(c.imu->bias, -0.01);
  EXPECT_EQ(c.imu->latency, 0.005);
  EXPECT_EQ(c.imu->noise_density, GyroOptions{}.noise_density);  // a key left out: the default
  const RobotConfig back = parse_config(format_config(c), "again.yaml");
  ASSERT_TRUE(back.imu);
  EXPECT_EQ(back.imu->scale, 1.02);
  EXPECT_EQ(back.imu->bias, -0.01);
  EXPECT_EQ(back.imu->max_rate, c.imu->max_rate);
  const auto error = [&](const std::string& text) {
    try {
      (void)parse_config(base + text, "robot.yaml");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error("imu:\n  scale: 0\n").find("scale"), std::string::npos);
  EXPECT_NE(error("imu:\n  bias: .nan\n").find("bias"), std::string::npos);
  EXPECT_NE(error("imu:\n  latency: 5\n").find("latency"), std::string::npos);
  EXPECT_NE(error("imu:\n  gain: 1\n").find("unknown key 'imu.gain'"), std::string::npos);
}

}  // namespace
}  // namespace moa::io
