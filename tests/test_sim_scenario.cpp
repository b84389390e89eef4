// Scenarios: the built-in ones are the example files and describe the
// papers' set-ups; a malformed scenario is rejected with a precise error.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>

#include "moa/formats/error.hpp"
#include "moa/sim/scenario.hpp"

namespace moa::sim {
namespace {

namespace fs = std::filesystem;
constexpr double kPi = std::numbers::pi;

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(SimScenario, BuiltinScenariosAreTheExampleFiles) {
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(fs::path(MOA_SOURCE_DIR) / "examples/scenarios")) {
    if (e.path().extension() != ".yaml") continue;
    const std::string stem = e.path().stem().string();
    files.push_back(stem);
    EXPECT_EQ(builtin_scenario_text(stem), slurp(e.path())) << stem;
    const Scenario s = load_scenario(e.path().string());
    EXPECT_EQ(s.name, stem);
  }
  std::sort(files.begin(), files.end());
  EXPECT_EQ(builtin_scenarios(), files);
  for (const char* name :
       {"sekimori-a", "sekimori-b", "kimlee", "calibration", "calib-mocap", "calib-camera"}) {
    EXPECT_NE(std::find(files.begin(), files.end(), name), files.end()) << name;
  }
}

TEST(SimScenario, SekimoriSensorsAreRadialAt45DegreeSteps) {
  for (const char* name : {"sekimori-a", "sekimori-b"}) {
    const Scenario s = load_scenario(name);
    ASSERT_EQ(s.nominal.array.size(), 4);
    for (int i = 0; i < 4; ++i) {
      const double phi = (45.0 + 90.0 * i) * kPi / 180.0;
      const SensorMount& m = s.nominal.array[i];
      EXPECT_NEAR(m.position.x(), 0.1 * std::cos(phi), 1e-15);
      EXPECT_NEAR(m.position.y(), 0.1 * std::sin(phi), 1e-15);
      EXPECT_NEAR(m.yaw, phi, 1e-15);
      EXPECT_EQ(m.cpi, 800.0);
      EXPECT_NEAR(*m.max_speed, 14.0 * 0.0254, 1e-15);
      // The real robot is within calibration accuracy of the nominal one.
      const SensorMount& t = s.truth.array[i];
      EXPECT_LT((t.position - m.position).norm(), 0.5e-3);
      EXPECT_LT(std::abs(t.yaw - m.yaw), 0.2 * kPi / 180.0);
      EXPECT_LT((t.scale - m.scale).cwiseAbs().maxCoeff(), 0.003);
    }
    EXPECT_EQ(s.sensor_model.frame_rate, 2300.0);
    EXPECT_EQ(s.drive.type, DriveType::kOmni3);
    EXPECT_TRUE(s.faults[0].tracking_loss.has_value());
  }
}

TEST(SimScenario, KimLeeGeometryIsEquations51And52) {
  const Scenario s = load_scenario("kimlee");
  // Eq. (51): 0.3 x [0.866 -0.500 0.000 1.000 -0.866 -0.500]; eq. (52) 1.05 x that.
  const double c = std::sqrt(3.0) / 2.0;
  const std::vector<Eigen::Vector2d> eq51 = {{0.3 * c, -0.15}, {0.0, 0.3}, {-0.3 * c, -0.15}};
  ASSERT_EQ(s.nominal.array.size(), 3);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR((s.nominal.array[i].position - eq51[i]).norm(), 0.0, 1e-15) << i;
    EXPECT_NEAR((s.truth.array[i].position - 1.05 * eq51[i]).norm(), 0.0, 1e-15) << i;
    EXPECT_EQ(s.nominal.array[i].yaw, 0.0);
    EXPECT_EQ(s.nominal.array[i].cpi, 1600.0);
  }
  EXPECT_EQ(s.sensor_model.frame_rate, 6400.0);
  EXPECT_EQ(s.sensor_model.packets_per_row, 12);
  EXPECT_EQ(s.drive.type, DriveType::kReference);
  const auto& program = std::get<TwistProgram>(s.motion);
  ASSERT_EQ(program.segments.size(), 1u);
  EXPECT_NEAR(program.segments[0].twist.omega, 1.0 / 3.0, 1e-16);
  EXPECT_EQ(program.segments[0].twist.v.norm(), 0.0);
}

TEST(SimScenario, CalibrationScenarioHasTheStatedErrors) {
  const Scenario s = load_scenario("calibration");
  int mirrored = 0;
  for (int i = 0; i < s.nominal.array.size(); ++i) {
    const SensorMount& n = s.nominal.array[i];
    const SensorMount& t = s.truth.array[i];
    EXPECT_LE((t.position - n.position).cwiseAbs().maxCoeff(), 0.008 + 1e-12);
    EXPECT_LE(std::abs(t.yaw - n.yaw), 4.0 * kPi / 180.0);
    EXPECT_LE((t.scale - n.scale).cwiseAbs().maxCoeff(), 0.04 + 1e-12);
    EXPECT_FALSE(n.mirrored);
    mirrored += t.mirrored;
  }
  EXPECT_EQ(mirrored, 1);
  EXPECT_EQ(s.drive.type, DriveType::kReference);
  EXPECT_GT(s.drive.noise_speed, 0.0);
}

// calib-mocap and calib-camera: calibration's robot, rows a few ms late, no
// wheels, 60 s; motion capture (120 Hz, 0.3 mm, 0.1 deg, 12 ms) or a ceiling
// camera (25 Hz, 2 mm, 60 ms, 5 ms jitter, 2 % dropped), as documented.
TEST(SimScenario, CalibrationAgainstACameraScenariosAreAsStated) {
  const Scenario calibration = load_scenario("calibration");
  for (const char* name : {"calib-mocap", "calib-camera"}) {
    const Scenario s = load_scenario(name);
    EXPECT_EQ(s.drive.type, DriveType::kNone) << name;
    EXPECT_NEAR(s.duration, 60.0, 1e-9) << name;
    ASSERT_EQ(s.truth.array.size(), 4) << name;
    const std::vector<double> latency = {0.002, 0.005, 0.008, 0.003};
    for (int i = 0; i < 4; ++i) {
      const auto u = static_cast<std::size_t>(i);
      const SensorMount& t = s.truth.array[i];
      const SensorMount& c = calibration.truth.array[i];
      EXPECT_EQ(t.position, c.position) << name << i;
      EXPECT_EQ(t.yaw, c.yaw) << name << i;
      EXPECT_EQ(t.scale, c.scale) << name << i;
      EXPECT_EQ(t.mirrored, c.mirrored) << name << i;
      EXPECT_NEAR(s.sensor_timing[u].latency, latency[u], 1e-15) << name << i;
      EXPECT_NEAR(t.latency, latency[u], 1e-7) << name << i;
      EXPECT_EQ(s.sensor_timing[u].jitter, 0.0) << name << i;
      EXPECT_EQ(s.nominal.array[i].latency, 0.0) << name << i;
    }
    EXPECT_FALSE(s.nominal.camera_latency.has_value()) << name;
    EXPECT_EQ(s.truth.camera_latency, s.camera.latency) << name;
  }
  const CameraModel mocap = load_scenario("calib-mocap").camera;
  EXPECT_EQ(mocap.mode, CameraMode::kMocap);
  EXPECT_EQ(mocap.rate, 120.0);
  EXPECT_EQ(mocap.noise, 0.0003);
  EXPECT_NEAR(mocap.heading_noise, 0.1 * kPi / 180.0, 1e-7);
  EXPECT_EQ(mocap.latency, 0.012);
  EXPECT_EQ(mocap.jitter, 0.0);
  EXPECT_EQ(mocap.drop, 0.0);
  const CameraModel ceiling = load_scenario("calib-camera").camera;
  EXPECT_EQ(ceiling.mode, CameraMode::kPositions);
  EXPECT_EQ(ceiling.rate, 25.0);
  EXPECT_EQ(ceiling.noise, 0.002);
  EXPECT_EQ(ceiling.latency, 0.060);
  EXPECT_EQ(ceiling.jitter, 0.005);
  EXPECT_EQ(ceiling.drop, 0.02);
}

// A valid scenario to break one key at a time.
constexpr const char* kValid = R"(version: 1
name: t
sensor_model: {preset: HDNS-2051}
sensors: {layout: radial, angles_deg: [0, 120, 240], distance: 0.1}
motion: {type: twists, segments: [{twist: [0.1, 0, 0], duration: 1}]}
)";

std::string error_of(const std::string& yaml) {
  try {
    parse_scenario(yaml, "s.yaml");
  } catch (const io::Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(SimScenario, ValidBaseParses) { EXPECT_EQ(error_of(kValid), "(no error)"); }

struct BadCase {
  const char* what;
  std::string yaml;
  std::string error;
};

class SimScenarioErrors : public ::testing::TestWithParam<BadCase> {};

TEST_P(SimScenarioErrors, NamesFileLineAndKey) {
  EXPECT_EQ(error_of(GetParam().yaml), GetParam().error) << GetParam().what;
}

std::string with(const std::string& line) { return std::string(kValid) + line; }

INSTANTIATE_TEST_SUITE_P(
    Cases, SimScenarioErrors,
    ::testing::Values(
        BadCase{"unknown top key", with("colour: red\n"),
                "s.yaml:6: unknown key 'colour' (known here: version, name, description, "
                "duration, truth_rate, sensor_model, sensors, true_sensors, drive, wheels, "
                "motion, faults, camera, imu, unobservable)"},
        BadCase{"unknown nested key",
                "version: 1\nname: t\nsensor_model: {preset: HDNS-2051, fps: 100}\n",
                "s.yaml:3: unknown key 'sensor_model.fps' (known here: preset, cpi, frame_rate, "
                "max_speed, packets_per_row, frame_noise, relative_noise, delta_limit, squal, "
                "squal_jitter)"},
        BadCase{"missing key", "version: 1\nname: t\nsensor_model: {preset: HDNS-2051}\n",
                "s.yaml:1: missing key 'sensors'"},
        BadCase{"missing version", "name: t\n", "s.yaml:1: missing key 'version'"},
        BadCase{"unsupported version", "version: 2\nname: t\n",
                "s.yaml:1: key 'version': 2 is not supported (expected 1)"},
        BadCase{"duplicate key", with("name: u\n"), "s.yaml:6: duplicate key 'name'"},
        BadCase{"not a number",
                "version: 1\nname: t\nsensor_model: {preset: HDNS-2051, frame_rate: fast}\n",
                "s.yaml:3: key 'sensor_model.frame_rate': 'fast' is not a number"},
        BadCase{"not finite", "version: 1\nname: t\nsensor_model: {preset: HDNS-2051, cpi: .inf}\n",
                "s.yaml:3: key 'sensor_model.cpi': '.inf' is not a finite number"},
        BadCase{"not positive",
                "version: 1\nname: t\nsensor_model: {preset: HDNS-2051, frame_rate: 0}\n",
                "s.yaml:3: key 'sensor_model.frame_rate': must be within [1, 1000000] (found 0)"},
        BadCase{"unknown preset", "version: 1\nname: t\nsensor_model: {preset: PMW3360}\n",
                "s.yaml:3: key 'sensor_model.preset': 'PMW3360' is not one of: HDNS-2051, "
                "ADNS-3080"},
        BadCase{"wrong names count",
                "version: 1\nname: t\nsensor_model: {preset: HDNS-2051}\nsensors: {layout: "
                "radial, angles_deg: [0, 180], distance: 0.1, names: [a]}\n",
                "s.yaml:4: key 'sensors.names': expected 2 names (one per sensor), found 1"},
        BadCase{"duplicate sensor name",
                "version: 1\nname: t\nsensor_model: {preset: HDNS-2051}\nsensors:\n  - {name: a, "
                "position: [0, 0], yaw: 0}\n  - {name: a, position: [0, 1], yaw: 0}\n",
                "s.yaml:5: key 'sensors': duplicate sensor name 'a'"},
        BadCase{"one sensor",
                "version: 1\nname: t\nsensor_model: {preset: HDNS-2051}\nsensors: {layout: "
                "radial, angles_deg: [0], distance: 0.1}\n",
                "s.yaml:4: key 'sensors': 1 sensors, expected 2 to 16 (1 with an imu:)"},
        BadCase{"true sensor unknown", with("true_sensors: {m9: {yaw_error: 0.1}}\n"),
                "s.yaml:6: key 'true_sensors': no sensor called 'm9' (sensors: m1, m2, m3)"},
        BadCase{"true sensor bad key", with("true_sensors: {m1: {yaw_err: 0.1}}\n"),
                "s.yaml:6: unknown key 'true_sensors.m1.yaw_err' (known here: position_error, "
                "position_scale, yaw_error, scale, mirrored, cpi, latency, jitter, speed_scale)"},
        // Stream clocks (K = 23 at 2300 frames/s: a mice row every 0.01 s).
        BadCase{"sensor latency over 1 s", with("true_sensors: {m1: {latency: 1.5}}\n"),
                "s.yaml:6: key 'true_sensors.m1.latency': must be within [-1, 1] (found 1.5)"},
        BadCase{"sensor jitter negative", with("true_sensors: {m2: {jitter: -0.001}}\n"),
                "s.yaml:6: key 'true_sensors.m2.jitter': must be >= 0 (found -0.001)"},
        BadCase{"sensor jitter of a row period", with("true_sensors: {m1: {jitter: 0.01}}\n"),
                "s.yaml:6: key 'true_sensors.m1.jitter': must be less than the row period "
                "(0.01 s), so that the stamps stay in order (found 0.01)"},
        BadCase{"wheels without a drive", with("wheels: {latency: 0.01}\n"),
                "s.yaml:6: key 'wheels': no drive, so no wheels.csv to stamp (give drive:)"},
        BadCase{"wheels unknown key", with("drive: {type: reference}\nwheels: {delay: 0.01}\n"),
                "s.yaml:7: unknown key 'wheels.delay' (known here: latency, jitter)"},
        BadCase{"wheels jitter of a row period",
                with("drive: {type: reference, rate: 50}\nwheels: {jitter: 0.02}\n"),
                "s.yaml:7: key 'wheels.jitter': must be less than the row period (0.02 s), so "
                "that the stamps stay in order (found 0.02)"},
        BadCase{"wheels latency over 60 s",
                with("drive: {type: reference}\nwheels: {latency: -61}\n"),
                "s.yaml:7: key 'wheels.latency': must be within [-60, 60] (found -61)"},
        BadCase{"camera mode unknown", with("camera: {mode: lidar, rate: 10, noise: 0.01}\n"),
                "s.yaml:6: key 'camera.mode': 'lidar' is not one of: positions, mocap"},
        BadCase{"mocap without heading noise",
                with("camera: {mode: mocap, rate: 100, noise: 0.001}\n"),
                "s.yaml:6: missing key 'camera.heading_noise'"},
        BadCase{"heading noise of a positions camera",
                with("camera: {rate: 10, noise: 0.01, heading_noise: 0.01}\n"),
                "s.yaml:6: key 'camera.heading_noise': not used by camera mode 'positions' (no "
                "theta; mode: mocap has one)"},
        BadCase{"heading noise negative",
                with("camera: {mode: mocap, rate: 100, noise: 0.001, heading_noise: -1}\n"),
                "s.yaml:6: key 'camera.heading_noise': must be >= 0 (found -1)"},
        BadCase{"drop over 1", with("camera: {rate: 10, noise: 0.01, drop: 1.5}\n"),
                "s.yaml:6: key 'camera.drop': must be within [0, 1] (found 1.5)"},
        BadCase{"camera jitter of a fix period",
                with("camera: {rate: 25, noise: 0.01, jitter: 0.05}\n"),
                "s.yaml:6: key 'camera.jitter': must be less than the row period (0.04 s), so "
                "that the stamps stay in order (found 0.05)"},
        BadCase{"camera latency over 60 s", with("camera: {rate: 10, noise: 0.01, latency: 90}\n"),
                "s.yaml:6: key 'camera.latency': must be within [-60, 60] (found 90)"},
        BadCase{"true sensor speed scale ratio",
                with("true_sensors: {m1: {speed_scale: {speeds: [0, 2], ratios: [1, 0.4]}}}\n"),
                "s.yaml:6: key 'true_sensors.m1.speed_scale': ratios[1]: must be within [0.5, "
                "1.5] (found 0.4)"},
        BadCase{"true sensor speed scale knots",
                with("true_sensors: {m1: {speed_scale: {speeds: [1], ratios: [1]}}}\n"),
                "s.yaml:6: key 'true_sensors.m1.speed_scale.speeds': expected 2 to 8 numbers, "
                "found 1"},
        BadCase{"position pair", with("true_sensors: {m1: {position_error: [0.1]}}\n"),
                "s.yaml:6: key 'true_sensors.m1.position_error': expected 2 numbers, found 1"},
        BadCase{"bad motion type",
                "version: 1\nname: t\nsensor_model: {preset: HDNS-2051}\nsensors: {layout: "
                "radial, angles_deg: [0, 180], distance: 0.1}\nmotion: {type: teleport}\n",
                "s.yaml:5: key 'motion.type': 'teleport' is not one of: waypoints, twists, sines"},
        BadCase{"key of another motion type",
                "version: 1\nname: t\nsensor_model: {preset: HDNS-2051}\nsensors: {layout: "
                "radial, angles_deg: [0, 180], distance: 0.1}\nmotion: {type: twists, segments: "
                "[{twist: [0, 0, 1], duration: 1}], pause: 1}\n",
                "s.yaml:5: unknown key 'motion.pause' (known here: type, segments, max_accel, "
                "max_angular_accel)"},
        BadCase{"one waypoint",
                "version: 1\nname: t\nsensor_model: {preset: HDNS-2051}\nsensors: {layout: "
                "radial, angles_deg: [0, 180], distance: 0.1}\nmotion: {type: waypoints, "
                "waypoints: [[0, 0, 0]], max_speed: 1, max_rate: 1, max_accel: 1, "
                "max_angular_accel: 1}\n",
                "s.yaml:5: key 'motion.waypoints': at least two waypoints are needed"},
        BadCase{"waypoint of two numbers",
                "version: 1\nname: t\nsensor_model: {preset: HDNS-2051}\nsensors: {layout: "
                "radial, angles_deg: [0, 180], distance: 0.1}\nmotion:\n  type: waypoints\n  "
                "waypoints:\n    - [0, 0, 0]\n    - [1, 0]\n",
                "s.yaml:9: key 'motion.waypoints': expected 3 numbers, found 2"},
        BadCase{"sideways differential",
                "version: 1\nname: t\nsensor_model: {preset: HDNS-2051}\nsensors: {layout: "
                "radial, angles_deg: [0, 180], distance: 0.1}\ndrive: {type: differential, "
                "wheel_distance: 0.1}\nmotion:\n  type: waypoints\n  waypoints:\n    - [0, 0, "
                "0]\n    - [0, 1, 0]\n  max_speed: 1\n  max_rate: 1\n  max_accel: 1\n  "
                "max_angular_accel: 1\n",
                "s.yaml:10: key 'motion.waypoints': segment 1 -> 2 needs sideways motion, which "
                "a differential drive cannot make"},
        BadCase{"wheel angles on a mecanum drive",
                with("drive: {type: mecanum, wheel_distance: 0.2, wheel_angles_deg: [0, 1, 2]}\n"),
                "s.yaml:6: key 'drive.wheel_angles_deg': not used by drive type 'mecanum'"},
        BadCase{
            "three slip bases for four mecanum wheels",
            with("drive: {type: mecanum, wheel_distance: 0.2, slip: {base: [0.1, 0.1, 0.1]}}\n"),
            "s.yaml:6: key 'drive.slip.base': expected 4 numbers, found 3"},
        BadCase{"slip burst ends before it starts",
                with("drive: {type: omni3, wheel_distance: 0.1, slip: {bursts: [{start: 2, end: 1, "
                     "slip: 0.5}]}}\n"),
                "s.yaml:6: key 'drive.slip.bursts[0].end': must be after start (1 <= 2)"},
        BadCase{"slip burst on a wheel that is not there",
                with("drive: {type: omni3, wheel_distance: 0.1, slip: {bursts: [{start: 0, end: 1, "
                     "slip: 0.5, wheel: 3}]}}\n"),
                "s.yaml:6: key 'drive.slip.bursts[0].wheel': must be within [0, 2] (found 3)"},
        BadCase{"unknown gyro fault", with("imu: {faults: [{type: drift, start: 1}]}\n"),
                "s.yaml:6: key 'imu.faults[0].type': 'drift' is not one of: stuck, bias_step"},
        BadCase{"stuck gyro without an end", with("imu: {faults: [{type: stuck, start: 1}]}\n"),
                "s.yaml:6: missing key 'imu.faults[0].end'"},
        BadCase{"absurd bias step", with("imu: {faults: [{type: bias_step, start: 1, step: 2}]}\n"),
                "s.yaml:6: key 'imu.faults[0].step': must be within [-1, 1] (found 2)"},
        BadCase{"unobservable not a list", with("unobservable: yes\n"),
                "s.yaml:6: key 'unobservable': expected a list of texts, found 'yes'"},
        BadCase{"drive key of another type",
                with("drive: {type: reference, wheel_distance: 0.1}\n"),
                "s.yaml:6: key 'drive.wheel_distance': not used by drive type 'reference'"},
        BadCase{
            "event on unknown sensor",
            with("faults:\n  events:\n    - {type: liftoff, sensor: m7, start: 0.1, end: 0.2}\n"),
            "s.yaml:8: key 'faults.events[0].sensor': no sensor called 'm7' (sensors: m1, "
            "m2, m3)"},
        BadCase{"event ends before it starts",
                with("faults:\n  events:\n    - {type: stuck, sensor: m1, start: 0.5, end: 0.2}\n"),
                "s.yaml:8: key 'faults.events[0].end': must be after start (0.2 <= 0.5)"},
        BadCase{"event after the run",
                with("faults:\n  events:\n    - {type: stuck, sensor: m1, start: 5, end: 6}\n"),
                "s.yaml:8: key 'faults.events[0].start': after the end of the run (1 s)"},
        BadCase{"drift without scale",
                with("faults:\n  events:\n    - {type: drift, sensor: m1, start: 0, end: 1}\n"),
                "s.yaml:8: missing key 'faults.events[0].scale'"},
        BadCase{"drift scale zero",
                with("faults:\n  events:\n    - {type: drift, sensor: m1, start: 0, end: 1, "
                     "scale: 0}\n"),
                "s.yaml:8: key 'faults.events[0].scale': must be > 0 (found 0)"},
        BadCase{"drift scale negative",
                with("faults:\n  events:\n    - {type: drift, sensor: m1, start: 0, end: 1, "
                     "scale: -0.5}\n"),
                "s.yaml:8: key 'faults.events[0].scale': must be > 0 (found -0.5)"},
        BadCase{"drift scale not finite",
                with("faults:\n  events:\n    - {type: drift, sensor: m1, start: 0, end: 1, "
                     "scale: .nan}\n"),
                "s.yaml:8: key 'faults.events[0].scale': '.nan' is not a finite number"},
        BadCase{"drift ramp negative",
                with("faults:\n  events:\n    - {type: drift, sensor: m1, start: 0, end: 1, "
                     "scale: 0.9, ramp: -1}\n"),
                "s.yaml:8: key 'faults.events[0].ramp': must be >= 0 (found -1)"},
        BadCase{"drift ramp not a number",
                with("faults:\n  events:\n    - {type: drift, sensor: m1, start: 0, end: 1, "
                     "scale: 0.9, ramp: soon}\n"),
                "s.yaml:8: key 'faults.events[0].ramp': 'soon' is not a number"},
        BadCase{"drift ramp infinite",
                with("faults:\n  events:\n    - {type: drift, sensor: m1, start: 0, end: 1, "
                     "scale: 0.9, ramp: .inf}\n"),
                "s.yaml:8: key 'faults.events[0].ramp': '.inf' is not a finite number"},
        BadCase{"key of another event type on a drift",
                with("faults:\n  events:\n    - {type: drift, sensor: m1, start: 0, end: 1, "
                     "scale: 0.9, retained: 1}\n"),
                "s.yaml:8: unknown key 'faults.events[0].retained' (known here: type, sensor, "
                "start, end, scale, ramp)"},
        BadCase{"dirty without retained",
                with("faults:\n  events:\n    - {type: dirty, sensor: m1, start: 0, end: 1}\n"),
                "s.yaml:8: missing key 'faults.events[0].retained'"},
        BadCase{"key of another event type",
                with("faults:\n  events:\n    - {type: stuck, sensor: m1, start: 0, end: 1, "
                     "magnitude: 3}\n"),
                "s.yaml:8: unknown key 'faults.events[0].magnitude' (known here: type, sensor, "
                "start, end)"},
        BadCase{"retained range",
                with("faults:\n  tracking_loss: {rate: 1, mean_duration: 0.1, retained: [0.6, "
                     "0.2]}\n"),
                "s.yaml:7: key 'faults.tracking_loss.retained': expected [min, max] with 0 <= "
                "min <= max <= 1"},
        BadCase{"duration shorter than motion", with("duration: 0.5\n"),
                "s.yaml:6: key 'duration': shorter than the motion (0.5 s < 1 s)"},
        BadCase{"camera without noise", with("camera: {rate: 10}\n"),
                "s.yaml:6: missing key 'camera.noise'"},
        BadCase{"invalid YAML", "version: 1\nname: [t\n",
                "s.yaml:3: invalid YAML: end of sequence flow not found"},
        BadCase{"not a map", "- 1\n- 2\n", "s.yaml:1: expected a map, found a list"},
        BadCase{"empty", "", "s.yaml: empty scenario"},
        // Hostile YAML: yaml-cpp 0.7's LoadAll() never returned on these.
        BadCase{"a stray comma", ",", "s.yaml:1: invalid YAML: ',' outside a [list] or {map}"},
        BadCase{"a stray comma and a tag", ",!",
                "s.yaml:1: invalid YAML: ',' outside a [list] or {map}"},
        BadCase{"a comma after an anchor", "&a ,",
                "s.yaml:1: invalid YAML: ',' outside a [list] or {map}"},
        BadCase{"a comma after a document", with("---\n,\n"),
                "s.yaml:6: expected one YAML document, found another"},
        BadCase{"deep nesting", "version: 1\nname: " + std::string(40, '[') + std::string(40, ']'),
                "s.yaml:2: lists and maps nested deeper than 32 levels"},
        // Numbers that overflowed the simulator's integer casts.
        BadCase{"frame rate too high",
                "version: 1\nname: t\nsensor_model: {preset: ADNS-3080, frame_rate: 1e30}\n",
                "s.yaml:3: key 'sensor_model.frame_rate': must be within [1, 1000000] (found "
                "1e+30)"},
        BadCase{"frame rate too low",
                "version: 1\nname: t\nsensor_model: {preset: ADNS-3080, frame_rate: 1e-300, "
                "frame_noise: 1e-10}\n",
                "s.yaml:3: key 'sensor_model.frame_rate': must be within [1, 1000000] (found "
                "1e-300)"},
        BadCase{"noise too large to write",
                "version: 1\nname: t\nsensor_model: {preset: ADNS-3080, frame_noise: 1e200}\n"
                "sensors: {layout: radial, angles_deg: [0, 120, 240], distance: 0.1}\n"
                "motion: {type: twists, segments: [{twist: [0.1, 0, 0], duration: 1}]}\n",
                "s.yaml:3: key 'sensor_model.frame_noise': the sensor noise it implies cannot be "
                "written to robot.yaml ('inf' is not a finite number)"},
        BadCase{"run too long", with("duration: 1e30\n"),
                "s.yaml:6: key 'duration': must be at most 86400 s (found 1e+30)"},
        BadCase{"run of 1e8 s", with("duration: 1e8\n"),
                "s.yaml:6: key 'duration': must be at most 86400 s (found 100000000)"},
        BadCase{"segment too long",
                "version: 1\nname: t\nsensor_model: {preset: HDNS-2051}\n"
                "sensors: {layout: radial, angles_deg: [0, 120, 240], distance: 0.1}\n"
                "motion: {type: twists, segments: [{twist: [0.1, 0, 0], duration: 1e30}]}\n",
                "s.yaml:5: key 'motion.segments[0].duration': must be at most 86400 s (found "
                "1e+30)"},
        BadCase{"too many frames",
                "version: 1\nname: t\nsensor_model: {preset: ADNS-3080, frame_rate: 1e6}\n"
                "sensors: {layout: radial, angles_deg: [0, 120, 240], distance: 0.1}\n"
                "motion: {type: twists, segments: [{twist: [0.1, 0, 0], duration: 2000}]}\n",
                "s.yaml:5: key 'motion': 2000 s at 1000000 frames/s is 2e+09 frames, at most "
                "1e+09"},
        BadCase{"truth rate too low", with("truth_rate: 1e-300\n"),
                "s.yaml:6: key 'truth_rate': must be within [0.001, 1000000] (found 1e-300)"}));

TEST(SimScenario, UnknownNameListsTheBuiltins) {
  try {
    load_scenario("sekimori-c");
    FAIL() << "no error";
  } catch (const io::Error& e) {
    EXPECT_EQ(
        std::string(e.what()),
        "scenario 'sekimori-c': not a built-in scenario (calib-camera, calib-mocap, calibration, "
        "cruise, differential, "
        "faults-bump, faults-cruise, faults-dirty, faults-drift, faults-floor, faults-liftoff, "
        "faults-runaway, "
        "faults-spikes, "
        "faults-stuck, faults-zero, guided, gyro-bump, gyro-bump-quiet, gyro-compact, gyro-one, "
        "gyro-papers, "
        "kimlee, "
        "sekimori-a, "
        "sekimori-b, "
        "selfcal-ramp, "
        "selfcal-step, speed-scale) and no such file");
  }
}

}  // namespace
}  // namespace moa::sim
