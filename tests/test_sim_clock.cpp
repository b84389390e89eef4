// The simulator's stream clocks, measured from the files `moa simulate`
// writes against the truth: a row's stamp minus the true end of its interval
// (a fix's: its capture) has the configured latency as its mean and the
// jitter's uniform spread (mean within 4 sigma of the uniform's variance
// over the row count, variance within 4 sigma of the sample variance's);
// stamps increase per stream, mice.csv is in stamp order with ties in config
// order, and a last, shorter row is kept after its predecessor; dropped
// fixes at their rate (binomial, 3 sigma); motion capture's
// heading error has the configured SD (chi-square, 4 sigma); robot.true.yaml
// carries the latencies and robot.yaml none; a scenario that only spells
// out the defaults writes the same bytes as one that leaves them out.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "moa/formats/config.hpp"
#include "moa/sim/log_writer.hpp"
#include "moa/sim/scenario.hpp"
#include "moa/sim/simulate.hpp"
#include "support/synth.hpp"

namespace moa::sim {
namespace {

namespace fs = std::filesystem;

// HDNS-2051: 2300 frames/s, K = 23: a mice row every 10 ms (ends r * 23 /
// 2300 s, r = 0, 1, ...). Wheels every 46 frames (20 ms, ends (r + 1) * 46 /
// 2300 s); the camera captures every 23 frames from t = 0, as truth.csv
// writes its rows.
constexpr double kFrameRate = 2300.0;
constexpr double kRowPeriod = 23.0 / kFrameRate;
constexpr double kWheelPeriod = 46.0 / kFrameRate;
constexpr double kCameraPeriod = 23.0 / kFrameRate;
constexpr double kDuration = 60.0;

struct Timing {
  double latency;
  double jitter;
};
// m2 and m4 share a latency without jitter: their rows tie, m2 first.
const std::vector<Timing> kSensors = {{0.002, 0.004}, {0.005, 0.0}, {-0.003, 0.008}, {0.005, 0.0}};
constexpr Timing kWheels{0.007, 0.006};
constexpr Timing kCamera{0.030, 0.004};
constexpr double kDrop = 0.1;
constexpr double kHeadingNoise = 0.01;  // rad

constexpr const char* kScenario = R"(version: 1
name: clocks
sensor_model: {preset: HDNS-2051, frame_noise: 0.05}
sensors: {layout: radial, angles_deg: [0, 90, 180, 270], distance: 0.1}
true_sensors:
  m1: {latency: 0.002, jitter: 0.004}
  m2: {latency: 0.005}
  m3: {latency: -0.003, jitter: 0.008}
  m4: {latency: 0.005, yaw_error: 0.01}
drive: {type: reference, rate: 50}
wheels: {latency: 0.007, jitter: 0.006}
camera: {mode: mocap, rate: 100, noise: 0.001, heading_noise: 0.01, latency: 0.03, jitter: 0.004,
         drop: 0.1}
truth_rate: 100
motion: {type: twists, segments: [{twist: [0.1, 0.05, 0.8], duration: 60}]}
)";

// A CSV file of log format v1: comment lines, a header, rows of numbers or names.
struct Table {
  std::map<std::string, std::size_t> column;
  std::vector<std::vector<std::string>> rows;
  double number(std::size_t row, const std::string& name) const {
    return std::stod(rows[row][column.at(name)]);
  }
};

Table read_table(const fs::path& file) {
  std::ifstream in(file);
  Table t;
  std::string line;
  bool header = true;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> fields;
    std::stringstream s(line);
    std::string field;
    while (std::getline(s, field, ',')) fields.push_back(field);
    if (header) {
      for (std::size_t i = 0; i < fields.size(); ++i) t.column[fields[i]] = i;
      header = false;
    } else {
      t.rows.push_back(fields);
    }
  }
  return t;
}

const fs::path& written_log() {
  static const fs::path dir = [] {
    const fs::path d = test::scratch_dir("sim-clock") / "log";
    write_log(parse_scenario(kScenario, "clocks.yaml"), 7, d);
    return d;
  }();
  return dir;
}

// Offsets (stamp minus true time) of one stream against its configuration.
void expect_timing(const std::vector<double>& offsets, const Timing& timing,
                   const std::string& what) {
  ASSERT_GT(offsets.size(), 1000u) << what;
  const double n = static_cast<double>(offsets.size());
  double sum = 0.0;
  double lo = offsets[0];
  double hi = offsets[0];
  for (const double d : offsets) {
    sum += d;
    lo = std::min(lo, d);
    hi = std::max(hi, d);
  }
  const double mean = sum / n;
  double sq = 0.0;
  for (const double d : offsets) sq += (d - timing.latency) * (d - timing.latency);
  const double var = sq / n;  // about the known mean
  const double j = timing.jitter;
  if (j == 0.0) {
    EXPECT_NEAR(lo, timing.latency, 1e-12) << what;
    EXPECT_NEAR(hi, timing.latency, 1e-12) << what;
    return;
  }
  // u ~ U[-j/2, j/2]: var j^2/12, and var(u^2) = j^4/80 - j^4/144 = j^4/180.
  EXPECT_NEAR(mean, timing.latency, 4.0 * j / std::sqrt(12.0 * n)) << what;
  EXPECT_NEAR(var, j * j / 12.0, 4.0 * std::sqrt(j * j * j * j / 180.0 / n)) << what;
  EXPECT_GE(lo, timing.latency - j / 2.0 - 1e-12) << what;
  EXPECT_LE(hi, timing.latency + j / 2.0 + 1e-12) << what;
  // The spread fills its interval: n draws leave less than 10 / n of it at either end.
  EXPECT_LT(lo, timing.latency - j / 2.0 + 10.0 * j / n) << what;
  EXPECT_GT(hi, timing.latency + j / 2.0 - 10.0 * j / n) << what;
}

TEST(SimClock, MiceStampsHaveEachSensorsLatencyAndJitterInStampOrder) {
  const Table mice = read_table(written_log() / "mice.csv");
  const std::map<std::string, int> index = {{"m1", 0}, {"m2", 1}, {"m3", 2}, {"m4", 3}};
  std::vector<std::vector<double>> stamps(kSensors.size());
  int ties = 0;
  for (std::size_t r = 0; r < mice.rows.size(); ++r) {
    const int i = index.at(mice.rows[r][mice.column.at("sensor")]);
    const double t = mice.number(r, "t");
    if (r > 0) {
      const double before = mice.number(r - 1, "t");
      ASSERT_GE(t, before) << "row " << r;
      if (t == before) {
        ++ties;
        EXPECT_LT(index.at(mice.rows[r - 1][mice.column.at("sensor")]), i) << "row " << r;
      }
    }
    stamps[static_cast<std::size_t>(i)].push_back(t);
  }
  // m2 and m4 tie on every row.
  EXPECT_GE(ties, static_cast<int>(kDuration / kRowPeriod));
  for (std::size_t i = 0; i < kSensors.size(); ++i) {
    const auto& s = stamps[i];
    ASSERT_EQ(s.size(), static_cast<std::size_t>(std::llround(kDuration / kRowPeriod)) + 1) << i;
    std::vector<double> offsets;
    for (std::size_t r = 0; r < s.size(); ++r) {
      if (r > 0) {
        EXPECT_GT(s[r], s[r - 1]) << "sensor " << i << " row " << r;
      }
      offsets.push_back(s[r] - static_cast<double>(r) * 23.0 / kFrameRate);
    }
    expect_timing(offsets, kSensors[i], "m" + std::to_string(i + 1));
  }
}

TEST(SimClock, WheelStampsHaveTheWheelsLatencyAndJitter) {
  const Table wheels = read_table(written_log() / "wheels.csv");
  ASSERT_EQ(wheels.rows.size(), static_cast<std::size_t>(std::llround(kDuration / kWheelPeriod)));
  std::vector<double> offsets;
  for (std::size_t r = 0; r < wheels.rows.size(); ++r) {
    const double t = wheels.number(r, "t");
    if (r > 0) {
      EXPECT_GT(t, wheels.number(r - 1, "t")) << r;
    }
    offsets.push_back(t - static_cast<double>(r + 1) * 46.0 / kFrameRate);
  }
  expect_timing(offsets, kWheels, "wheels");
}

TEST(SimClock, CameraFixesAreLateJitteredDroppedAtTheirRateWithHeadingNoise) {
  const Table camera = read_table(written_log() / "camera.csv");
  const Table truth = read_table(written_log() / "truth.csv");
  ASSERT_TRUE(camera.column.contains("theta"));
  const auto captures = static_cast<std::size_t>(std::llround(kDuration / kCameraPeriod)) + 1;
  ASSERT_EQ(truth.rows.size(), captures);  // truth.csv at every capture, t = 0 included
  std::vector<double> offsets;
  double chi2 = 0.0;
  std::size_t previous = 0;
  for (std::size_t r = 0; r < camera.rows.size(); ++r) {
    const double t = camera.number(r, "t");
    // t_arrival repeats the stamp, to 9 significant digits.
    EXPECT_NEAR(camera.number(r, "t_arrival"), t, 1e-8 * std::abs(t) + 1e-12);
    // The capture this fix belongs to: the jitter is under half a period.
    const auto k = static_cast<std::size_t>(std::llround((t - kCamera.latency) / kCameraPeriod));
    ASSERT_LT(k, captures);
    if (r > 0) {
      EXPECT_GT(k, previous) << r;
      EXPECT_GT(t, camera.number(r - 1, "t")) << r;
    }
    previous = k;
    const double capture = static_cast<double>(k) * 23.0 / kFrameRate;
    ASSERT_NEAR(truth.number(k, "t"), capture, 1e-12);
    offsets.push_back(t - capture);
    const double theta = camera.number(r, "theta");
    EXPECT_LE(std::abs(theta), std::numbers::pi + 1e-9);
    const double e = std::remainder(theta - truth.number(k, "theta"), 2.0 * std::numbers::pi);
    chi2 += e * e / (kHeadingNoise * kHeadingNoise);
  }
  expect_timing(offsets, kCamera, "camera");
  // Dropped: Binomial(captures, 0.1), 3 sigma.
  const double n = static_cast<double>(captures);
  const double dropped = n - static_cast<double>(camera.rows.size());
  EXPECT_NEAR(dropped / n, kDrop, 3.0 * std::sqrt(kDrop * (1.0 - kDrop) / n));
  // sum e^2 / sigma^2 ~ chi^2(m): mean m, variance 2 m; 4 sigma.
  const double m = static_cast<double>(camera.rows.size());
  EXPECT_NEAR(chi2, m, 4.0 * std::sqrt(2.0 * m));
}

TEST(SimClock, TrueConfigCarriesTheLatenciesTheBelievedOneNone) {
  const io::RobotConfig truth = io::read_config(written_log() / "robot.true.yaml");
  const io::RobotConfig believed = io::read_config(written_log() / "robot.yaml");
  for (int i = 0; i < truth.array.size(); ++i) {
    EXPECT_NEAR(truth.array[i].latency, kSensors[static_cast<std::size_t>(i)].latency, 1e-7) << i;
    EXPECT_EQ(believed.array[i].latency, 0.0) << i;
  }
  EXPECT_EQ(truth.camera_latency, kCamera.latency);
  EXPECT_EQ(truth.wheels_latency, kWheels.latency);
  EXPECT_FALSE(believed.camera_latency.has_value());
  EXPECT_FALSE(believed.wheels_latency.has_value());
}

// A last, shorter wheel interval (2300 frames = 45 rows of 51 and one of 5:
// 2.2 ms) with a jitter of 20 ms can draw a stamp before its predecessor's;
// it is put just after it. Over 40 seeds that happens (P ~ 0.4 each), and
// every run's stamps increase.
TEST(SimClock, AShortLastWheelRowIsStampedAfterItsPredecessor) {
  const Scenario s = parse_scenario(R"(version: 1
name: short
sensor_model: {preset: HDNS-2051}
sensors: {layout: radial, angles_deg: [0, 180], distance: 0.1}
drive: {type: reference, rate: 45}
wheels: {latency: 0.01, jitter: 0.02}
motion: {type: twists, segments: [{twist: [0.1, 0, 0], duration: 1}]}
)",
                                    "short.yaml");
  int clamped = 0;
  for (std::uint64_t seed = 1; seed <= 40; ++seed) {
    const SimLog log = simulate(s, seed);
    ASSERT_EQ(log.wheels.size(), 46u);
    for (std::size_t r = 1; r < log.wheels.size(); ++r) {
      ASSERT_GT(log.wheels[r].t, log.wheels[r - 1].t) << seed << " " << r;
    }
    const double before = log.wheels[44].t;
    const double last = log.wheels[45].t;
    // The drawn stamp lies within +-jitter/2 of 1 s + latency; a clamped one
    // is the next double after its predecessor.
    if (last == std::nextafter(before, 2.0)) {
      ++clamped;
    } else {
      EXPECT_NEAR(last, 1.01, 0.01 + 1e-12) << seed;
    }
  }
  EXPECT_GT(clamped, 0);
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(SimClock, DefaultsSpelledOutWriteTheSameBytes) {
  const std::string base = R"(version: 1
name: same
sensor_model: {preset: HDNS-2051, frame_noise: 0.05}
sensors: {layout: radial, angles_deg: [0, 120, 240], distance: 0.1}
drive: {type: omni3, wheel_distance: 0.11, slip: {random: 0.01}}
motion: {type: twists, segments: [{twist: [0.1, 0.05, 0.5], duration: 5}]}
)";
  const std::string plain = base + "camera: {rate: 10, noise: 0.005, latency: 0.1}\n";
  const std::string spelled =
      base +
      "true_sensors: {m1: {latency: 0, jitter: 0}}\nwheels: {latency: 0, jitter: 0}\n"
      "camera: {mode: positions, rate: 10, noise: 0.005, latency: 0.1, jitter: 0, drop: 0}\n";
  const fs::path dir = test::scratch_dir("sim-clock-same");
  write_log(parse_scenario(plain, "plain.yaml"), 3, dir / "a");
  write_log(parse_scenario(spelled, "spelled.yaml"), 3, dir / "b");
  for (const char* file : {"mice.csv", "wheels.csv", "camera.csv", "truth.csv", "faults.csv",
                           "robot.yaml", "robot.true.yaml"}) {
    const std::string a = slurp(dir / "a" / file);
    EXPECT_FALSE(a.empty()) << file;
    EXPECT_EQ(a, slurp(dir / "b" / file)) << file;
  }
}

}  // namespace
}  // namespace moa::sim
