// The host side of the Cortex-M4F program under QEMU (embedded/odometry_qemu.cpp):
//
//   qemu_stream pack CONFIG LOG OUT.bin [--estimator E] [--sensors A,B] [--rate HZ]
//                                       [--no-wheels] [--fuse-camera] [--self-calibrate]
//     packs a log for the device (embedded/qemu_stream.hpp): the config's
//     mounts, the options (resolved as `moa odometry` resolves its flags), then
//     mice rows (with faults.csv's fault bits for the oracle), wheel rows and
//     camera fixes in exactly the order io::run_odometry feeds them to the
//     pipeline, and the end time.
//
//   qemu_stream compare CONFIG ODOMETRY.csv POSES.bin POSE_TOL TWIST_TOL PER_TICK
//     compares the device's steps with `moa odometry`'s odometry.csv on the
//     same log and options: the same number of steps, the same epoch times
//     and used sensors exactly, |dx|, |dy| (m) and |dtheta| (rad) within
//     POSE_TOL, |dvx|, |dvy| (m/s) and |domega| (rad/s) within TWIST_TOL,
//     and the device's SysTick calibration at PER_TICK instructions per tick
//     (within 0.1 %: else the instruction counts are not instructions).
//     Prints the largest differences and the device's instruction counts;
//     exits 1 when a check fails.
//
//   qemu_stream csv POSES.bin OUT.csv
//     writes the device's steps as odometry.csv's first seven columns
//     (t,x,y,theta,vx,vy,omega; shortest round-trip digits), for `moa evaluate`.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "moa/formats/config.hpp"
#include "moa/formats/csv.hpp"
#include "moa/formats/log.hpp"
#include "moa/formats/odometry_csv.hpp"
#include "moa/runs/odometry_run.hpp"
#include "qemu_stream.hpp"

namespace {

namespace q = moa::qemu;

int usage() {
  std::cerr
      << "usage: qemu_stream pack CONFIG LOG OUT.bin [--estimator E] [--sensors A,B] "
         "[--rate HZ] [--no-wheels] [--fuse-camera] [--self-calibrate]\n"
         "       qemu_stream compare CONFIG ODOMETRY.csv POSES.bin POSE_TOL TWIST_TOL PER_TICK\n"
         "       qemu_stream csv POSES.bin OUT.csv\n";
  return 2;
}

template <class T>
void put(std::ofstream& out, const T& value) {
  out.write(reinterpret_cast<const char*>(&value), sizeof(value));
}

int pack(int argc, char** argv) {
  if (argc < 5) return usage();
  const std::string config_path = argv[2];
  std::string estimator = "consensus";
  double rate = moa::OdometryOptions{}.rate;
  bool no_wheels = false, fuse_camera = false, self_calibrate = false;
  std::vector<std::string> sensors;
  for (int i = 5; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--estimator" && i + 1 < argc) {
      estimator = argv[++i];
    } else if (a == "--sensors" && i + 1 < argc) {
      std::string list = argv[++i];
      for (std::size_t start = 0; start <= list.size();) {
        const std::size_t comma = std::min(list.find(',', start), list.size());
        sensors.push_back(list.substr(start, comma - start));
        start = comma + 1;
      }
    } else if (a == "--rate" && i + 1 < argc) {
      rate = std::stod(argv[++i]);
    } else if (a == "--no-wheels") {
      no_wheels = true;
    } else if (a == "--fuse-camera") {
      fuse_camera = true;
    } else if (a == "--self-calibrate") {
      self_calibrate = true;
    } else {
      return usage();
    }
  }
  const moa::io::RobotConfig config = moa::io::read_config(config_path);
  moa::OdometryOptions o;
  o.rate = rate;
  o.fuse_camera = fuse_camera;
  o.self_calibration.enabled = self_calibrate;
  o = moa::io::resolve_odometry_options(o, estimator, sensors, no_wheels, config, config_path);
  const moa::io::LogFiles log = moa::io::resolve_log(argv[3]);
  moa::io::MiceReader mice(log.mice, config);
  // The oracle's faults.csv: one row per mice.csv row, in the same order
  // (io::run_odometry checks t and sensor; so does this).
  std::unique_ptr<moa::io::CsvReader> faults;
  std::size_t faults_t = 0, faults_sensor = 0, faults_bits = 0;
  if (o.estimator == moa::EstimatorKind::kOracle) {
    if (!log.faults) {
      std::cerr << "qemu_stream: the oracle needs the simulator's faults.csv\n";
      return 1;
    }
    faults = std::make_unique<moa::io::CsvReader>(*log.faults);
    faults_t = faults->required_column("t");
    faults_sensor = faults->required_column("sensor");
    faults_bits = faults->required_column("faults");
  }

  std::ofstream out(argv[4], std::ios::binary);
  q::StreamHeader header{};
  std::memcpy(header.magic, q::kInputMagic, sizeof(header.magic));
  header.sensors = static_cast<std::uint32_t>(config.array.size());
  header.estimator = static_cast<std::uint32_t>(o.estimator);
  header.use_wheels = o.use_wheels ? 1 : 0;
  header.fuse_camera = o.fuse_camera ? 1 : 0;
  header.selected = o.sensors;
  header.self_calibrate = o.self_calibration.enabled ? 1 : 0;
  header.rate = o.rate;
  header.max_row_interval = o.max_row_interval;
  header.max_gap = o.max_gap;
  header.t0 = mice.start_time();
  put(out, header);
  for (const moa::SensorMount& m : config.array.mounts()) {
    q::StreamMount s{};
    s.x = m.position.x();
    s.y = m.position.y();
    s.yaw = m.yaw;
    s.cpi = m.cpi;
    s.scale_x = m.scale.x();
    s.scale_y = m.scale.y();
    s.mirrored = m.mirrored ? 1 : 0;
    s.has_max_speed = m.max_speed ? 1 : 0;
    s.max_speed = m.max_speed.value_or(0.0);
    s.has_noise = m.noise ? 1 : 0;
    s.noise = m.noise.value_or(0.0);
    put(out, s);
  }

  // The merge of io::run_odometry: before each mice row, the camera fixes
  // and then the wheel rows up to its time; after the last, those up to it.
  std::unique_ptr<moa::io::WheelsReader> wheels;
  if (o.use_wheels && log.wheels) wheels = std::make_unique<moa::io::WheelsReader>(*log.wheels);
  std::unique_ptr<moa::io::CameraReader> camera;
  if (o.fuse_camera) {
    if (!log.camera) {
      std::cerr << "qemu_stream: --fuse-camera needs camera.csv in the log\n";
      return 1;
    }
    camera = std::make_unique<moa::io::CameraReader>(*log.camera);
  }
  std::optional<moa::io::WheelRow> wheel = wheels ? wheels->next() : std::nullopt;
  std::optional<moa::io::CameraRow> fix = camera ? camera->next() : std::nullopt;
  std::size_t counts[4] = {};
  const auto feed_until = [&](double t) {
    while (fix && fix->t <= t) {
      q::StreamRecord r{};
      r.kind = q::RecordKind::kFix;
      r.t = fix->t;
      r.a = fix->position.x();
      r.b = fix->position.y();
      r.has_theta = fix->theta ? 1 : 0;
      r.c = fix->theta.value_or(0.0);
      r.has_sigma = fix->sigma ? 1 : 0;
      if (fix->sigma) {
        r.sx = fix->sigma->x();
        r.sy = fix->sigma->y();
      }
      put(out, r);
      ++counts[2];
      fix = camera->next();
    }
    while (wheel && wheel->t <= t) {
      q::StreamRecord r{};
      r.kind = q::RecordKind::kWheels;
      r.t = wheel->t;
      r.a = wheel->twist.v.x();
      r.b = wheel->twist.v.y();
      r.c = wheel->twist.omega;
      put(out, r);
      ++counts[1];
      wheel = wheels->next();
    }
  };
  double t_end = header.t0;
  while (auto row = mice.next()) {
    feed_until(row->t);
    q::StreamRecord r{};
    r.kind = q::RecordKind::kMice;
    r.t = row->t;
    r.sensor = row->sensor;
    r.a = row->counts.x();
    r.b = row->counts.y();
    r.has_squal = row->squal ? 1 : 0;
    r.squal = row->squal.value_or(0);
    r.flags = row->flags;
    if (faults) {
      if (!faults->next() || faults->number(faults_t) != row->t ||
          config.index_of(faults->field(faults_sensor)) != row->sensor) {
        std::cerr << "qemu_stream: faults.csv does not match mice.csv row by row\n";
        return 1;
      }
      r.faults = static_cast<std::uint8_t>(faults->integer(faults_bits, 0, 255));
    }
    put(out, r);
    ++counts[0];
    t_end = row->t;
  }
  feed_until(t_end);
  q::StreamRecord end{};
  end.kind = q::RecordKind::kEnd;
  end.t = t_end;
  put(out, end);
  out.close();
  if (!out) {
    std::cerr << "qemu_stream: cannot write " << argv[4] << "\n";
    return 1;
  }
  std::cout << "qemu_stream: packed " << counts[0] << " mice rows, " << counts[1] << " wheel rows, "
            << counts[2] << " camera fixes (" << to_name(o.estimator) << ", " << o.rate
            << " Hz) into " << argv[4] << "\n";
  return 0;
}

/// The device's output file: its steps and its summary; false (and a
/// message) when the file is not one.
bool read_poses(const char* file, std::vector<q::StreamPose>& poses, q::StreamSummary& summary) {
  std::ifstream in(file, std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.size() < sizeof(q::StreamSummary) ||
      (bytes.size() - sizeof(q::StreamSummary)) % sizeof(q::StreamPose) != 0) {
    std::cerr << "qemu_stream: " << file << ": not the device's output (" << bytes.size()
              << " bytes)\n";
    return false;
  }
  std::memcpy(&summary, bytes.data() + bytes.size() - sizeof(summary), sizeof(summary));
  if (std::memcmp(summary.magic, q::kOutputMagic, sizeof(summary.magic)) != 0) {
    std::cerr << "qemu_stream: " << file << ": no summary record\n";
    return false;
  }
  poses.resize((bytes.size() - sizeof(summary)) / sizeof(q::StreamPose));
  std::memcpy(poses.data(), bytes.data(), poses.size() * sizeof(q::StreamPose));
  return true;
}

int csv(int argc, char** argv) {
  if (argc != 4) return usage();
  q::StreamSummary summary{};
  std::vector<q::StreamPose> poses;
  if (!read_poses(argv[2], poses, summary)) return 1;
  std::ofstream out(argv[3]);
  out << "t,x,y,theta,vx,vy,omega\n";
  char line[256];
  for (const auto& p : poses) {
    std::snprintf(line, sizeof(line), "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", p.t, p.x, p.y,
                  p.theta, p.vx, p.vy, p.omega);
    out << line;
  }
  out.close();
  if (!out) {
    std::cerr << "qemu_stream: cannot write " << argv[3] << "\n";
    return 1;
  }
  return 0;
}

int compare(int argc, char** argv) {
  if (argc != 8) return usage();
  const std::string config_path = argv[2];
  const moa::io::RobotConfig config = moa::io::read_config(config_path);
  const double pose_tol = std::stod(argv[5]);
  const double twist_tol = std::stod(argv[6]);
  const double expected_per_tick = std::stod(argv[7]);

  q::StreamSummary summary{};
  std::vector<q::StreamPose> poses;
  if (!read_poses(argv[4], poses, summary)) return 1;

  moa::io::OdometryCsvReader reference(argv[3], config, config_path);
  std::size_t n = 0, failures = 0;
  double max_pose = 0.0, max_theta = 0.0, max_twist = 0.0;
  std::size_t identical = 0;
  const auto report = [&](std::size_t i, const std::string& what) {
    if (++failures <= 10) std::cerr << "qemu_stream: step " << i << ": " << what << "\n";
  };
  while (auto row = reference.next()) {
    const std::size_t i = n++;
    if (i >= poses.size()) continue;
    const q::StreamPose& p = poses[i];
    if (p.t != row->t) report(i, "t " + std::to_string(p.t) + " vs " + std::to_string(row->t));
    if (reference.has_selection() && p.used != row->used) report(i, "used sensors differ");
    const double dp = std::max(std::abs(p.x - row->pose.t.x()), std::abs(p.y - row->pose.t.y()));
    const double dtheta = std::abs(p.theta - row->pose.theta);
    const double dv =
        std::max({std::abs(p.vx - row->twist.v.x()), std::abs(p.vy - row->twist.v.y()),
                  std::abs(p.omega - row->twist.omega)});
    if (!(dp <= pose_tol) || !(dtheta <= pose_tol)) report(i, "pose differs");
    if (!(dv <= twist_tol)) report(i, "twist differs");
    max_pose = std::max(max_pose, dp);
    max_theta = std::max(max_theta, dtheta);
    max_twist = std::max(max_twist, dv);
    if (dp == 0.0 && dtheta == 0.0 && dv == 0.0) ++identical;
  }
  if (n != poses.size()) {
    std::cerr << "qemu_stream: " << poses.size() << " steps from the device, " << n
              << " in the reference\n";
    ++failures;
  }
  if (summary.refused_rows != 0) {
    std::cerr << "qemu_stream: the device's pipeline refused " << summary.refused_rows
              << " records\n";
    ++failures;
  }
  const double per_tick = static_cast<double>(summary.calibration_instructions) /
                          static_cast<double>(summary.calibration_ticks);
  if (!(std::abs(per_tick - expected_per_tick) <= 1e-3 * expected_per_tick)) {
    std::fprintf(stderr,
                 "qemu_stream: the device's SysTick counted %.4f instructions per tick, not %g: "
                 "was QEMU run with -icount shift=0?\n",
                 per_tick, expected_per_tick);
    ++failures;
  }
  std::uint32_t largest = 0;  // the calls up to one step (an epoch made final)
  for (const auto& p : poses) largest = std::max(largest, p.instructions);
  std::printf(
      "qemu_stream: %zu steps; bit-identical %zu; largest |difference|: position %.3g m, "
      "heading %.3g rad, twist %.3g (m/s, rad/s); tolerances %.3g, %.3g\n",
      n, identical, max_pose, max_theta, max_twist, pose_tol, twist_tol);
  if (summary.steps != 0) {
    std::printf(
        "qemu_stream: device: %.0f instructions per step on average (%llu over %llu steps; "
        "SysTick %.3f instructions per tick); at most %u in the calls up to one step; stack "
        "%llu bytes, %llu below the program's main frame\n",
        static_cast<double>(summary.pipeline_instructions) / static_cast<double>(summary.steps),
        static_cast<unsigned long long>(summary.pipeline_instructions),
        static_cast<unsigned long long>(summary.steps), per_tick, largest,
        static_cast<unsigned long long>(summary.stack_bytes),
        static_cast<unsigned long long>(summary.pipeline_stack_bytes));
  }
  return failures == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) try {
  if (argc < 2) return usage();
  const std::string command = argv[1];
  if (command == "pack") return pack(argc, argv);
  if (command == "compare") return compare(argc, argv);
  if (command == "csv") return csv(argc, argv);
  return usage();
} catch (const std::exception& e) {
  std::cerr << "qemu_stream: " << e.what() << "\n";
  return 1;
}
