// The Python module `moa` (docs/python.md): the library's readers, the
// odometry pipeline, calibration, the simulator and evaluation, with numpy
// arrays in and out. It converts and forwards; what it computes is the
// library's (io::run_odometry, io::calibrate_log, sim::simulate, ...).
#include <fmt/core.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "moa/analysis/evaluate.hpp"
#include "moa/core/odometry.hpp"
#include "moa/core/plausible.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/log.hpp"
#include "moa/formats/odometry_csv.hpp"
#include "moa/runs/calibration_run.hpp"
#include "moa/runs/evaluate.hpp"
#include "moa/runs/odometry_run.hpp"
#include "moa/sim/log_writer.hpp"
#include "moa/sim/scenario.hpp"
#include "moa/sim/simulate.hpp"

namespace py = pybind11;
namespace fs = std::filesystem;

namespace moa::python {
namespace {

// ------------------------------------------------------------ numpy helpers

/// A numpy array that owns `v` (moved, not copied).
template <class T>
py::array_t<T> to_numpy(std::vector<T>&& v, std::vector<py::ssize_t> shape = {}) {
  auto* owner = new std::vector<T>(std::move(v));
  py::capsule free(owner, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  if (shape.empty()) shape = {static_cast<py::ssize_t>(owner->size())};
  return py::array_t<T>(shape, owner->data(), free);
}

/// A numpy array of str (numpy's unicode dtype).
py::array to_numpy_str(const std::vector<std::string>& v, std::vector<py::ssize_t> shape = {}) {
  py::list items;
  for (const auto& s : v) items.append(s);
  py::array a = py::module_::import("numpy").attr("array")(items, py::arg("dtype") = "U");
  if (!shape.empty()) a = a.attr("reshape")(py::tuple(py::cast(shape)));
  return a;
}

/// A 1-d float array from any sequence (or None: empty).
std::vector<double> doubles(const py::handle& x) {
  if (x.is_none()) return {};
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(x);
  if (!a) throw py::type_error("expected a sequence of numbers");
  return {a.data(), a.data() + a.size()};
}

/// A SQUAL value, 0..255 (negative means absent, as read_log gives it).
std::uint8_t squal_value(double squal) {
  if (!(squal <= 255.0)) throw py::value_error(fmt::format("squal {}: must be 0..255", squal));
  return static_cast<std::uint8_t>(squal);
}

// ------------------------------------------------------------ config

/// A robot config: a path (str or os.PathLike) or a Config.
struct Config {
  io::RobotConfig config;
  std::string path;  ///< where it was read from, for messages
};

Config load_config(const py::handle& config) {
  if (py::isinstance<Config>(config)) return config.cast<Config>();
  const fs::path path = config.cast<fs::path>();
  return {io::read_config(path), path.string()};
}

py::dict config_dict(const io::RobotConfig& c) {
  const auto n = static_cast<std::size_t>(c.array.size());
  std::vector<double> position, yaw, cpi, scale, max_speed, noise, latency;
  py::array_t<bool> mirrored(static_cast<py::ssize_t>(n));
  for (std::size_t i = 0; i < n; ++i) {
    const SensorMount& m = c.array[static_cast<int>(i)];
    position.insert(position.end(), {m.position.x(), m.position.y()});
    yaw.push_back(m.yaw);
    cpi.push_back(m.cpi);
    scale.insert(scale.end(), {m.scale.x(), m.scale.y()});
    mirrored.mutable_at(static_cast<py::ssize_t>(i)) = m.mirrored;
    max_speed.push_back(m.max_speed.value_or(std::nan("")));
    noise.push_back(m.noise.value_or(std::nan("")));
    latency.push_back(m.latency);
  }
  const auto rows = static_cast<py::ssize_t>(n);
  py::dict d;
  d["names"] = c.names;
  d["position"] = to_numpy(std::move(position), {rows, 2});
  d["yaw"] = to_numpy(std::move(yaw));
  d["cpi"] = to_numpy(std::move(cpi));
  d["scale"] = to_numpy(std::move(scale), {rows, 2});
  d["mirrored"] = mirrored;
  d["max_speed"] = to_numpy(std::move(max_speed));
  d["noise"] = to_numpy(std::move(noise));
  d["latency"] = to_numpy(std::move(latency));  // s, per sensor
  // s, None when the config does not say
  d["camera_latency"] = c.camera_latency ? py::cast(*c.camera_latency) : py::none();
  d["wheels_latency"] = c.wheels_latency ? py::cast(*c.wheels_latency) : py::none();
  // The imu: block, its keys as the YAML names them; None when the config has none.
  if (c.imu) {
    const GyroOptions& g = *c.imu;
    py::dict imu;
    imu["scale"] = static_cast<double>(g.scale);
    imu["bias"] = static_cast<double>(g.bias);
    imu["noise_density"] = static_cast<double>(g.noise_density);
    imu["bias_random_walk"] = static_cast<double>(g.bias_random_walk);
    imu["bias_sigma"] = static_cast<double>(g.bias_sigma);
    imu["scale_sigma"] = static_cast<double>(g.scale_sigma);
    imu["mount_yaw_sigma"] = static_cast<double>(g.mount_yaw_sigma);
    imu["max_rate"] = static_cast<double>(g.max_rate);
    imu["latency"] = g.latency;  // s
    d["imu"] = imu;
  } else {
    d["imu"] = py::none();
  }
  return d;
}

// ------------------------------------------------------------ options

/// Keyword options; an unknown one is a TypeError naming it.
class Options {
 public:
  Options(const py::kwargs& kwargs, std::set<std::string> known, const char* what) {
    for (const auto& [key, value] : kwargs) {
      const auto name = key.cast<std::string>();
      if (!known.count(name)) {
        std::string list;
        for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
        throw py::type_error(
            fmt::format("{}: unknown option '{}' (options: {})", what, name, list));
      }
      if (!value.is_none()) values_[name] = py::reinterpret_borrow<py::object>(value);
    }
  }
  template <class T>
  std::optional<T> get(const std::string& name) const {
    const auto it = values_.find(name);
    if (it == values_.end()) return std::nullopt;
    return it->second.cast<T>();
  }
  template <class T>
  void set(const std::string& name, T& target) const {
    if (auto v = get<T>(name)) target = *v;
  }

 private:
  std::map<std::string, py::object> values_;
};

const std::set<std::string> kOdometryOptions{
    "sensors",      "rate",     "no_wheels", "no_imu", "fuse_camera",  "camera_latency",
    "camera_sigma", "e_th",     "r_th",      "alpha",  "initial_pose", "max_row_interval",
    "max_gap",      "ekf_scale"};

/// `moa odometry`'s flags as keywords, resolved as the command line does.
OdometryOptions odometry_options(const std::string& estimator, const py::kwargs& kwargs,
                                 const Config& config) {
  const Options o(kwargs, kOdometryOptions, "odometry");
  OdometryOptions options;
  o.set("rate", options.rate);
  // The command line's bound of --rate (0.1 to 10000 Hz): 1e6 made 1.36 GB
  // of epochs of a 3 s log.
  // (NaN and infinity: the options' own check, "invalid option: rate: ...".)
  if (std::isfinite(options.rate) && !(options.rate >= 0.1 && options.rate <= 10000.0)) {
    throw io::Error(fmt::format("rate: {}: must be within [0.1, 10000]", options.rate));
  }
  o.set("fuse_camera", options.fuse_camera);
  if (const auto latency = o.get<double>("camera_latency")) options.camera_latency = *latency;
  o.set("camera_sigma", options.camera_sigma);
  o.set("ekf_scale", options.ekf.estimate_scale);
  o.set("e_th", options.sekimori.e_th);
  o.set("r_th", options.sekimori.r_th);
  o.set("alpha", options.consensus.alpha);
  options.max_row_interval = o.get<double>("max_row_interval")
                                 .value_or(OdometryOptions::default_max_row_interval(options.rate));
  o.set("max_gap", options.max_gap);
  options.use_imu = !o.get<bool>("no_imu").value_or(false);
  if (const auto pose = o.get<std::vector<double>>("initial_pose")) {
    if (pose->size() != 3) throw py::value_error("initial_pose: expected (x, y, theta)");
    options.initial = Pose2{{(*pose)[0], (*pose)[1]}, (*pose)[2]};
  }
  std::vector<std::string> sensors;
  if (const auto s = o.get<py::object>("sensors")) {
    sensors = py::isinstance<py::str>(*s) ? std::vector<std::string>{s->cast<std::string>()}
                                          : s->cast<std::vector<std::string>>();
  }
  return io::resolve_odometry_options(options, estimator, sensors,
                                      o.get<bool>("no_wheels").value_or(false), config.config,
                                      config.path);
}

// ------------------------------------------------------------ steps

/// Steps collected column by column: the columns of odometry.csv.
class Steps {
 public:
  explicit Steps(int n_sensors) : n_(n_sensors) {}

  void add(const OdometryStep& step) {
    const RobustEstimate& e = step.estimate;
    const Eigen::Matrix3d& c = e.estimate.covariance;
    for (const double v :
         {step.t(), step.pose.t.x(), step.pose.t.y(), step.pose.theta, e.estimate.twist.v.x(),
          e.estimate.twist.v.y(), e.estimate.twist.omega, std::sqrt(std::max(c(0, 0), 0.0)),
          std::sqrt(std::max(c(1, 1), 0.0)), std::sqrt(std::max(c(2, 2), 0.0))}) {
      numbers_[column_++ % kColumns].push_back(v);
    }
    const Eigen::Matrix3d& p = step.pose_covariance;
    for (const double v : {p(0, 0), p(0, 1), p(1, 1), p(2, 2)}) covariance_.push_back(v);
    fused_ = fused_ || step.fused;
    for (const double v :
         {step.scale(0), step.scale(1), std::sqrt(std::max(step.scale_covariance(0, 0), 0.0)),
          std::sqrt(std::max(step.scale_covariance(1, 1), 0.0))}) {
      scale_.push_back(v);
    }
    scaled_ = scaled_ || step.scaled;
    source_.emplace_back(to_name(e.source));
    heading_.emplace_back(io::heading_source(e));
    gyro_test_.push_back(e.tests.gyro);
    for (int i = 0; i < n_; ++i) {
      const bool used = contains(e.estimate.used, i);
      const auto u = static_cast<std::size_t>(i);
      used_.push_back(used);
      excluded_.push_back(used ? std::string()
                               : io::describe_exclusion(e.excluded[u], e.noise_flags[u]));
      noise_flags_.push_back(e.noise_flags[u]);
    }
  }

  std::size_t size() const { return source_.size(); }

  /// The columns as numpy arrays; the collector is empty afterwards.
  py::dict take(const std::vector<std::string>& names) {
    static constexpr std::array<const char*, kColumns> kNames{
        "t", "x", "y", "theta", "vx", "vy", "omega", "sd_vx", "sd_vy", "sd_omega"};
    py::dict d;
    const auto k = static_cast<py::ssize_t>(size());
    const auto n = static_cast<py::ssize_t>(n_);
    for (std::size_t c = 0; c < kColumns; ++c) d[kNames[c]] = to_numpy(std::move(numbers_[c]));
    d["source"] = to_numpy_str(source_);
    d["heading"] = to_numpy_str(heading_);
    d["gyro_test"] = to_numpy(std::move(gyro_test_));
    py::array_t<bool> used({k, n});
    for (py::ssize_t j = 0; j < k * n; ++j)
      used.mutable_data()[j] = used_[static_cast<std::size_t>(j)];
    d["used"] = used;
    d["excluded"] = to_numpy_str(excluded_, {k, n});
    d["noise_flags"] = to_numpy(std::move(noise_flags_), {k, n});
    d["names"] = names;
    if (fused_) {
      std::array<std::vector<double>, 4> cov;
      for (std::size_t j = 0; j < covariance_.size(); ++j) cov[j % 4].push_back(covariance_[j]);
      d["pxx"] = to_numpy(std::move(cov[0]));
      d["pxy"] = to_numpy(std::move(cov[1]));
      d["pyy"] = to_numpy(std::move(cov[2]));
      d["ptt"] = to_numpy(std::move(cov[3]));
    }
    if (scaled_) {
      std::array<std::vector<double>, 4> scale;
      for (std::size_t j = 0; j < scale_.size(); ++j) scale[j % 4].push_back(scale_[j]);
      d["scale_v"] = to_numpy(std::move(scale[0]));
      d["scale_omega"] = to_numpy(std::move(scale[1]));
      d["sd_scale_v"] = to_numpy(std::move(scale[2]));
      d["sd_scale_omega"] = to_numpy(std::move(scale[3]));
    }
    *this = Steps(n_);
    return d;
  }

 private:
  static constexpr std::size_t kColumns = 10;
  int n_;
  std::size_t column_ = 0;
  std::array<std::vector<double>, kColumns> numbers_;
  std::vector<double> covariance_;
  bool fused_ = false;
  std::vector<double> scale_;  ///< scale_v, scale_omega, sd_scale_v, sd_scale_omega per step
  bool scaled_ = false;
  std::vector<std::string> source_;
  std::vector<std::string> heading_;  ///< gyro, or the source
  std::vector<double> gyro_test_;     ///< the gyro's test ratio (NaN: not tested)
  std::vector<bool> used_;
  std::vector<std::string> excluded_;
  std::vector<std::uint8_t> noise_flags_;
};

py::dict odometry(const py::object& config_path, const fs::path& log, const std::string& estimator,
                  const py::kwargs& kwargs) {
  const Config config = load_config(config_path);
  const OdometryOptions options = odometry_options(estimator, kwargs, config);
  Steps steps(config.config.array.size());
  io::OdometryRun run;
  {
    py::gil_scoped_release release;
    run = io::run_odometry(config.config, config.path, io::resolve_log(log), options,
                           [&](const OdometryStep& s) { steps.add(s); });
  }
  py::dict out = steps.take(config.config.names);
  out["summary"] = py::cast(run.summary);
  return out;
}

/// The pipeline fed from Python.
class PyOdometry {
  /// Collects the steps a call emits.
  struct Sink {
    Steps* steps;
    void operator()(const OdometryStep& s) const { steps->add(s); }
  };
  Sink sink() { return Sink{&steps_}; }

 public:
  PyOdometry(const py::object& config, double t0, const std::string& estimator,
             const py::kwargs& kwargs)
      : config_(load_config(config)),
        odometry_(io::make_odometry(config_.config, config_.path, checked_t0(t0),
                                    odometry_options(estimator, kwargs, config_))),
        steps_(config_.config.array.size()),
        t_last_(t0) {}

  /// t0 as the logs' times are bounded (a NaN t0 made push loop for ever).
  static double checked_t0(double t0) {
    if (!(std::abs(t0) <= kMaxTime)) {
      throw io::Error(fmt::format("t0 = {} s: not a time within -4e9..4e9 s", t0));
    }
    return t0;
  }

  /// A count as mice.csv holds it: an integer (of a double's exact range).
  static double count(double x, const char* what) {
    if (!(std::abs(x) <= 9007199254740992.0) || std::floor(x) != x) {
      throw io::Error(fmt::format("{} {}: a count is a whole number", what, x));
    }
    return x;
  }
  /// A count given as a Python number: a bool is no count (True read as 1).
  static double count(const py::handle& x, const char* what) {
    if (py::isinstance<py::bool_>(x)) {
      throw io::Error(fmt::format("{} {}: a count is a whole number, not a bool", what,
                                  py::str(x).cast<std::string>()));
    }
    return count(x.cast<double>(), what);
  }
  /// The counts of push_rows: an array of bools is no counts either.
  static void no_bools(const py::handle& x, const char* what) {
    const auto kind = py::module_::import("numpy")
                          .attr("asarray")(x)
                          .attr("dtype")
                          .attr("kind")
                          .cast<std::string>();
    if (kind == "b") throw io::Error(fmt::format("{}: counts are whole numbers, not bools", what));
  }
  /// The flags byte (bit 0 overflow, 1 lift), as mice.csv's 0..255.
  static std::uint8_t flags_value(double flags) {
    if (!(flags >= 0.0 && flags <= 255.0) || std::floor(flags) != flags) {
      throw io::Error(fmt::format("flags {}: must be a whole number 0..255", flags));
    }
    return static_cast<std::uint8_t>(flags);
  }

  int sensor_index(const py::handle& sensor) const {
    if (py::isinstance<py::str>(sensor)) {
      const auto name = sensor.cast<std::string>();
      const auto i = config_.config.index_of(name);
      if (!i) throw io::Error(fmt::format("unknown sensor '{}' ({})", name, config_.path));
      return *i;
    }
    return sensor.cast<int>();
  }

  void check(std::optional<OdometryError> error, double t) {
    if (!error) return;
    const char* detail =
        *error == OdometryError::kRow ? describe(odometry_->row_error()) : describe(*error);
    steps_ = Steps(config_.config.array.size());
    throw io::Error(fmt::format("row at t = {} s: {}", t, detail));
  }

  py::dict push(double t, const py::handle& sensor, const py::handle& dx, const py::handle& dy,
                std::optional<int> squal, long long flags) {
    SensorRow row{t,
                  sensor_index(sensor),
                  {count(dx, "dx"), count(dy, "dy")},
                  std::nullopt,
                  flags_value(static_cast<double>(flags))};
    if (squal && *squal >= 0) row.squal = squal_value(*squal);
    check(odometry_->push(row, sink()), t);
    t_last_ = std::max(t_last_, t);
    return steps_.take(config_.config.names);
  }

  py::dict push_rows(const py::handle& t, const py::handle& sensor, const py::handle& dx,
                     const py::handle& dy, const py::handle& squal, const py::handle& flags) {
    no_bools(dx, "dx");
    no_bools(dy, "dy");
    const auto tt = doubles(t), xx = doubles(dx), yy = doubles(dy), qq = doubles(squal),
               ff = doubles(flags);
    std::vector<int> ss;
    for (const auto& s : py::iter(sensor)) ss.push_back(sensor_index(s));
    const std::size_t n = tt.size();
    if (ss.size() != n || xx.size() != n || yy.size() != n || (!qq.empty() && qq.size() != n) ||
        (!ff.empty() && ff.size() != n)) {
      throw py::value_error("push_rows: t, sensor, dx, dy (and squal, flags) must have one length");
    }
    for (std::size_t k = 0; k < n; ++k) {
      SensorRow row{tt[k], ss[k], {count(xx[k], "dx"), count(yy[k], "dy")}, std::nullopt, 0};
      if (!qq.empty() && qq[k] >= 0.0) row.squal = squal_value(qq[k]);
      if (!ff.empty()) row.flags = flags_value(ff[k]);
      check(odometry_->push(row, sink()), tt[k]);
      t_last_ = std::max(t_last_, tt[k]);
    }
    return steps_.take(config_.config.names);
  }

  py::dict push_wheels(double t, double vx, double vy, double omega) {
    check(odometry_->push_wheels(t, Twist2{{vx, vy}, omega}, sink()), t);
    return steps_.take(config_.config.names);
  }

  void push_fix(double t, double x, double y, std::optional<double> theta, std::optional<double> sx,
                std::optional<double> sy) {
    CameraFix fix{t, {x, y}, theta, std::nullopt};
    if (sx && sy) fix.sigma = Eigen::Vector2d(*sx, *sy);
    check(odometry_->push_fix(fix), t);
  }

  /// Ends the stream at t_end: no earlier than the last mice row, and at
  /// most max_gap after it (finish(1e6) made a million still epochs).
  py::dict finish(double t_end) {
    const double max_gap = odometry_->options().max_gap;
    if (!(std::abs(t_end) <= kMaxTime && t_end >= t_last_ && t_end - t_last_ <= max_gap)) {
      throw io::Error(fmt::format(
          "finish: t_end = {} s: must be from the last row's time ({} s) to max_gap ({} s) after "
          "it",
          t_end, t_last_, max_gap));
    }
    odometry_->finish(t_end, sink());
    return steps_.take(config_.config.names);
  }

  py::tuple pose() const {
    const Pose2& p = odometry_->pose();
    return py::make_tuple(p.t.x(), p.t.y(), p.theta);
  }
  std::size_t steps() const { return odometry_->steps(); }
  const std::vector<std::string>& names() const { return config_.config.names; }

 private:
  Config config_;
  std::unique_ptr<Odometry> odometry_;
  Steps steps_;
  double t_last_;  ///< s, the last mice row's time (t0 before any)
};

// ------------------------------------------------------------ calibration

py::dict mount_dict(const SensorMount& m) {
  py::dict d;
  d["position"] = to_numpy(std::vector<double>{m.position.x(), m.position.y()});
  d["yaw"] = m.yaw;
  d["scale"] = to_numpy(std::vector<double>{m.scale.x(), m.scale.y()});
  d["mirrored"] = m.mirrored;
  d["cpi"] = m.cpi;
  return d;
}

py::dict sensor_dict(const io::SensorCalibrationReport& s) {
  py::dict d = mount_dict(s.calibrated);
  d["name"] = s.name;
  d["sd_position"] = to_numpy(std::vector<double>{s.sigma(0), s.sigma(1)});
  d["sd_yaw"] = s.sigma(2);
  d["sd_scale"] = to_numpy(std::vector<double>{s.sigma(3), s.sigma(4)});
  py::dict estimated;
  const std::array<const char*, kMountParameters> keys{"position_x", "position_y", "yaw", "scale_x",
                                                       "scale_y"};
  for (std::size_t p = 0; p < keys.size(); ++p) estimated[keys[p]] = s.estimated[p];
  d["estimated"] = estimated;
  d["mirror_from_data"] = s.mirror_from_data;
  d["nominal"] = mount_dict(s.nominal);
  d["residual_rms"] = s.residual_rms ? py::cast(*s.residual_rms) : py::none();
  d["push_misfit"] = s.push_misfit ? py::cast(*s.push_misfit) : py::none();
  if (s.information_eigenvalues) {
    const MountVector& e = *s.information_eigenvalues;
    d["information_eigenvalues"] = to_numpy(std::vector<double>(e.data(), e.data() + e.size()));
  } else {
    d["information_eigenvalues"] = py::none();
  }
  return d;
}

const std::set<std::string> kCalibrationOptions{"max_row_interval",
                                                "min_interval",
                                                "measurements",
                                                "push_x",
                                                "push_y",
                                                "spin",
                                                "distance",
                                                "turns",
                                                "distance_sd",
                                                "turn_sd",
                                                "centre_sd",
                                                "heading_sd",
                                                "force",
                                                "no_imu",
                                                "imu_reference",
                                                "reference",
                                                "max_offset",
                                                "window"};

io::CalibrationSummary calibrate(const py::object& config_path, const py::object& log,
                                 const std::string& method_name, const py::kwargs& kwargs) {
  const auto method = from_name<io::CalibrationMethod>(method_name);
  if (!method) {
    throw io::Error(
        fmt::format("--method: unknown method '{}' (kimlee, exact, guided)", method_name));
  }
  const Options o(kwargs, kCalibrationOptions, "calibrate");
  io::CalibrationOptions options;
  o.set("max_row_interval", options.max_row_interval);
  options.min_interval = o.get<double>("min_interval");
  options.measurements = o.get<int>("measurements");
  o.set("push_x", options.push_x);
  o.set("push_y", options.push_y);
  o.set("spin", options.spin);
  options.distance = o.get<double>("distance");
  options.turns = o.get<double>("turns");
  o.set("distance_sd", options.tolerances.distance_sd);
  o.set("turn_sd", options.tolerances.turn_sd);
  o.set("centre_sd", options.tolerances.centre_sd);
  o.set("heading_sd", options.tolerances.heading_sd);
  o.set("force", options.force);
  options.imu = !o.get<bool>("no_imu").value_or(false);
  if (const auto reference = o.get<std::string>("imu_reference")) {
    const auto r = from_name<io::GyroReference>(*reference);
    if (!r) {
      throw io::Error(fmt::format(
          "imu_reference: unknown reference '{}' (array, array-nominal, wheels, camera)",
          *reference));
    }
    options.imu_reference = *r;
  }
  if (const auto reference = o.get<std::string>("reference")) {
    const auto r = from_name<io::ExactReference>(*reference);
    if (!r)
      throw io::Error(
          fmt::format("reference: unknown reference '{}' (wheels, camera)", *reference));
    options.reference = *r;
  }
  o.set("max_offset", options.max_offset);
  o.set("window", options.window);
  const fs::path log_path = log.is_none() ? fs::path() : log.cast<fs::path>();
  io::check_calibration_options(*method, log_path, options);
  const Config config = load_config(config_path);
  py::gil_scoped_release release;
  return io::calibrate_log(config.config, config.path, log_path, *method, options);
}

// ------------------------------------------------------------ logs and the simulator

py::dict mice_dict(std::vector<double>&& t, std::vector<std::int32_t>&& sensor,
                   std::vector<double>&& dx, std::vector<double>&& dy,
                   std::vector<std::int16_t>&& squal, std::vector<std::uint8_t>&& flags) {
  py::dict d;
  d["t"] = to_numpy(std::move(t));
  d["sensor"] = to_numpy(std::move(sensor));
  d["dx"] = to_numpy(std::move(dx));
  d["dy"] = to_numpy(std::move(dy));
  d["squal"] = to_numpy(std::move(squal));
  d["flags"] = to_numpy(std::move(flags));
  return d;
}

py::dict columns(std::vector<const char*> names, std::vector<std::vector<double>>&& values) {
  py::dict d;
  for (std::size_t i = 0; i < names.size(); ++i) d[names[i]] = to_numpy(std::move(values[i]));
  return d;
}

py::dict read_log(const py::object& config_path, const fs::path& log) {
  const Config config = load_config(config_path);
  const io::LogFiles files = io::resolve_log(log);
  py::dict d;
  {
    io::MiceReader reader(files.mice, config.config);
    std::vector<double> t, dx, dy;
    std::vector<std::int32_t> sensor;
    std::vector<std::int16_t> squal;
    std::vector<std::uint8_t> flags;
    while (const auto row = reader.next()) {
      t.push_back(row->t);
      sensor.push_back(row->sensor);
      dx.push_back(row->counts.x());
      dy.push_back(row->counts.y());
      squal.push_back(row->squal ? static_cast<std::int16_t>(*row->squal) : std::int16_t{-1});
      flags.push_back(row->flags);
    }
    d["mice"] = mice_dict(std::move(t), std::move(sensor), std::move(dx), std::move(dy),
                          std::move(squal), std::move(flags));
  }
  if (files.wheels) {
    std::vector<std::vector<double>> v(4);
    for (const auto& r : io::read_all<io::WheelRow>(*files.wheels)) {
      for (std::size_t i = 0; const double x : {r.t, r.twist.v.x(), r.twist.v.y(), r.twist.omega})
        v[i++].push_back(x);
    }
    d["wheels"] = columns({"t", "vx", "vy", "omega"}, std::move(v));
  }
  if (files.imu) {
    std::vector<std::vector<double>> v(2);
    for (const auto& r : io::read_all<io::ImuRow>(*files.imu)) {
      v[0].push_back(r.t);
      v[1].push_back(r.gz);
    }
    d["imu"] = columns({"t", "gz"}, std::move(v));
  }
  if (files.camera) {
    std::vector<std::vector<double>> v(6);
    const double nan = std::nan("");
    for (const auto& r : io::read_all<io::CameraRow>(*files.camera)) {
      for (std::size_t i = 0;
           const double x : {r.t, r.position.x(), r.position.y(), r.theta.value_or(nan),
                             r.sigma ? r.sigma->x() : nan, r.sigma ? r.sigma->y() : nan})
        v[i++].push_back(x);
    }
    d["camera"] = columns({"t", "x", "y", "theta", "sx", "sy"}, std::move(v));
  }
  if (files.truth) {
    std::vector<std::vector<double>> v(4);
    for (const auto& r : io::read_all<io::TruthRow>(*files.truth)) {
      for (std::size_t i = 0; const double x : {r.t, r.pose.t.x(), r.pose.t.y(), r.pose.theta})
        v[i++].push_back(x);
    }
    d["truth"] = columns({"t", "x", "y", "theta"}, std::move(v));
  }
  d["names"] = config.config.names;
  return d;
}

py::dict simulate(const std::string& scenario_name, std::uint64_t seed,
                  const std::optional<fs::path>& out) {
  const sim::Scenario scenario = sim::load_scenario(scenario_name);
  sim::SimLog log;
  {
    py::gil_scoped_release release;
    log = sim::simulate(scenario, seed);
    // The same seed gives the same records: the files are this run.
    if (out) sim::write_log(scenario, seed, *out);
  }
  py::dict d;
  {
    std::vector<double> t, dx, dy;
    std::vector<std::int32_t> sensor;
    std::vector<std::int16_t> squal;
    std::vector<std::uint8_t> flags, faults;
    for (const auto& r : log.mice) {
      t.push_back(r.t);
      sensor.push_back(r.sensor);
      dx.push_back(r.row.counts.x());
      dy.push_back(r.row.counts.y());
      squal.push_back(r.row.squal);
      flags.push_back(r.row.flags);
      faults.push_back(r.row.faults);
    }
    py::dict mice = mice_dict(std::move(t), std::move(sensor), std::move(dx), std::move(dy),
                              std::move(squal), std::move(flags));
    mice["faults"] = to_numpy(std::move(faults));
    d["mice"] = mice;
  }
  {
    std::vector<std::vector<double>> v(4);
    for (const auto& r : log.wheels) {
      for (std::size_t i = 0; const double x : {r.t, r.twist.v.x(), r.twist.v.y(), r.twist.omega})
        v[i++].push_back(x);
    }
    d["wheels"] = columns({"t", "vx", "vy", "omega"}, std::move(v));
  }
  {
    std::vector<std::vector<double>> v(2);
    for (const auto& r : log.imu) {
      v[0].push_back(r.t);
      v[1].push_back(r.gz);
    }
    d["imu"] = columns({"t", "gz"}, std::move(v));
  }
  {
    std::vector<std::vector<double>> v(5);
    std::vector<bool> outlier;
    for (const auto& r : log.camera) {
      for (std::size_t i = 0;
           const double x : {r.t, r.t_arrival, r.position.x(), r.position.y(), r.sigma})
        v[i++].push_back(x);
      outlier.push_back(r.outlier);
    }
    py::dict camera = columns({"t", "t_arrival", "x", "y", "sigma"}, std::move(v));
    py::array_t<bool> o(static_cast<py::ssize_t>(outlier.size()));
    for (std::size_t i = 0; i < outlier.size(); ++i)
      o.mutable_at(static_cast<py::ssize_t>(i)) = outlier[i];
    camera["outlier"] = o;
    if (scenario.camera.mode == sim::CameraMode::kMocap) {  // motion capture: the heading too
      py::array_t<double> theta(static_cast<py::ssize_t>(log.camera.size()));
      for (std::size_t i = 0; i < log.camera.size(); ++i)
        theta.mutable_at(static_cast<py::ssize_t>(i)) = log.camera[i].theta.value_or(0.0);
      camera["theta"] = theta;
    }
    d["camera"] = camera;
  }
  {
    std::vector<std::vector<double>> v(7);
    for (const auto& r : log.truth) {
      for (std::size_t i = 0; const double x : {r.t, r.pose.t.x(), r.pose.t.y(), r.pose.theta,
                                                r.twist.v.x(), r.twist.v.y(), r.twist.omega})
        v[i++].push_back(x);
    }
    d["truth"] = columns({"t", "x", "y", "theta", "vx", "vy", "omega"}, std::move(v));
  }
  d["config"] = py::cast(Config{scenario.nominal, scenario.name + ": nominal"});
  d["true_config"] = py::cast(Config{scenario.truth, scenario.name + ": truth"});
  d["names"] = scenario.nominal.names;
  return d;
}

py::dict error_dict(const TrajectoryError& e) {
  py::dict d;
  for_each_member(e, [&d](const char* name, const auto& value) { d[name] = value; });
  return d;
}

std::vector<StampedPose> trajectory(const py::handle& x, const char* what) {
  const py::dict d = py::reinterpret_borrow<py::dict>(x);
  std::vector<std::vector<double>> c;
  for (const char* key : {"t", "x", "y", "theta"}) {
    if (!d.contains(key)) throw py::key_error(fmt::format("{}: no '{}' array", what, key));
    c.push_back(doubles(d[key]));
    if (c.back().size() != c.front().size()) {
      throw py::value_error(fmt::format("{}: t, x, y, theta must have one length", what));
    }
  }
  // As the readers of truth.csv and odometry.csv check them: times within
  // the logs' bound and never going back (decreasing times gave 0 samples
  // and an error of 0.0, a perfect run), poses within the plausible.
  std::vector<StampedPose> out;
  for (std::size_t k = 0; k < c[0].size(); ++k) {
    const double t = c[0][k];
    if (!(std::abs(t) <= kMaxTime)) {
      throw io::Error(fmt::format("{}: t[{}] = {} s is outside -4e9..4e9 s", what, k, t));
    }
    if (k > 0 && t < c[0][k - 1]) {
      throw io::Error(fmt::format("{}: t[{}] = {} s: time goes backwards ({} after {})", what, k, t,
                                  t, c[0][k - 1]));
    }
    if (!within_plausible(c[1][k], kMaxPlausiblePosition) ||
        !within_plausible(c[2][k], kMaxPlausiblePosition) ||
        !within_plausible(c[3][k], kMaxPlausibleHeading)) {
      throw io::Error(fmt::format(
          "{}: pose {} ({}, {}, {}) beyond the plausible (|x|, |y| <= 1e6 m, |theta| <= 1e7 rad)",
          what, k, c[1][k], c[2][k], c[3][k]));
    }
    out.push_back({t, {{c[1][k], c[2][k]}, c[3][k]}});
  }
  return out;
}

py::dict evaluate(const py::object& truth, const py::object& odometry) {
  if (!py::isinstance<py::dict>(truth) && !py::isinstance<py::dict>(odometry)) {
    return error_dict(io::evaluate_files(truth.cast<fs::path>(), odometry.cast<fs::path>()));
  }
  if (!py::isinstance<py::dict>(truth) || !py::isinstance<py::dict>(odometry)) {
    throw py::type_error("evaluate: give two paths or two dicts of arrays (t, x, y, theta)");
  }
  const std::vector<StampedPose> t = trajectory(truth, "truth"),
                                 o = trajectory(odometry, "odometry");
  TrajectoryErrorAccumulator acc(t);
  for (const auto& p : o) acc.add(p.t, p.pose);
  return error_dict(acc.result());
}

}  // namespace
}  // namespace moa::python

PYBIND11_MODULE(moa, m) {
  using namespace moa;
  using namespace moa::python;
  m.doc() = R"(moa: robot velocity and pose from the counts of several optical mouse sensors.

The library's pipeline, calibration, simulator and evaluation, with numpy
arrays in and out. Units are SI (m, s, rad); poses are world_T_robot (x, y,
theta), twists are in the robot frame (vx, vy in m/s, omega in rad/s).
Errors in files and options raise moa.Error with the message `moa` prints.
See docs/python.md.)";

  py::register_exception<io::Error>(m, "Error", PyExc_RuntimeError);
  m.attr("__version__") = MOA_VERSION;

  py::class_<Config>(m, "Config", R"(A robot config v1 (docs/formats/config.md).

Config(path) reads a YAML file; Config.from_yaml(text) parses text.)")
      .def(py::init([](const fs::path& path) {
             return Config{io::read_config(path), path.string()};
           }),
           py::arg("path"))
      .def_static(
          "from_yaml",
          [](const std::string& text, const std::string& source) {
            return Config{io::parse_config(text, source), source};
          },
          py::arg("text"), py::arg("source") = "<yaml>",
          "Parses config YAML; `source` names it in errors.")
      .def_property_readonly(
          "names", [](const Config& c) { return c.config.names; }, "Sensor names, in config order.")
      .def_property_readonly("path", [](const Config& c) { return c.path; })
      .def(
          "to_yaml", [](const Config& c) { return io::format_config(c.config); },
          "The config as YAML text (what `moa calibrate --out` writes).")
      .def(
          "to_dict", [](const Config& c) { return config_dict(c.config); },
          "The sensors as arrays and the optional blocks: see moa.read_config.")
      .def("__len__", [](const Config& c) { return c.config.names.size(); })
      .def("__repr__", [](const Config& c) {
        return fmt::format("<moa.Config {} ({} sensors)>", c.path, c.config.names.size());
      });

  m.def(
      "read_config", [](const fs::path& path) { return config_dict(io::read_config(path)); },
      py::arg("path"), R"(Reads a robot config v1 into arrays.

Returns a dict: names (list of str), position (N, 2) m robot frame, yaw (N,)
rad, cpi (N,), scale (N, 2), mirrored (N,) bool, max_speed (N,) m/s and noise
(N,) m/s (NaN where the config gives none), latency (N,) s, camera_latency and
wheels_latency (s, None where the config gives none), imu (the imu: block as a
dict: scale, bias, noise_density, bias_random_walk, bias_sigma, scale_sigma,
mount_yaw_sigma, max_rate, latency; None where the config has none).)");

  m.def("read_log", &read_log, py::arg("config"), py::arg("log_dir"),
        R"(Reads a log directory (or its mice.csv) into arrays.

Returns a dict with "mice": t (s), sensor (index in the config), dx, dy
(counts, sensor frame), squal (-1 where absent), flags; and, for the files
present, "wheels": t, vx, vy, omega; "imu": t, gz (rad/s, as imu.csv holds
it); "camera": t, x, y, theta, sx, sy (NaN where absent); "truth": t, x, y,
theta; and "names".)");

  m.def("odometry", &odometry, py::arg("config"), py::arg("log_dir"),
        py::arg("estimator") = "consensus",
        R"(Runs `moa odometry` on a log; returns its columns as arrays.

config: path of robot.yaml (or a moa.Config); log_dir: the log directory or
its mice.csv; estimator: ls, sekimori, consensus, wheels or oracle.
Options, as the command's flags: sensors (list of names), rate (Hz),
no_wheels, fuse_camera, camera_latency (s), camera_sigma (m), e_th (m^2),
r_th, alpha, initial_pose (x, y, theta), max_row_interval (s; default 0.05,
or 60 epochs where that is shorter), max_gap (s),
ekf_scale.

Returns a dict of arrays, one row per epoch, equal to odometry.csv: t (s,
epoch end), x, y, theta (world_T_robot), vx, vy, omega (robot frame), sd_vx,
sd_vy, sd_omega, source (str: mice, wheels, hold); per sensor (K, N):
used (bool), excluded (str: '' when used, else the reason and noise flags as
odometry.csv writes them, e.g. 'inconsistent/over-speed'), noise_flags
(uint8 bits: 1 over-speed, 2 low-squal, 4 overflow); names; with
fuse_camera pxx, pxy, pyy (m^2), ptt (rad^2); with ekf_scale too scale_v,
scale_omega, sd_scale_v, sd_scale_omega (1).)");

  py::class_<PyOdometry>(m, "Odometry", R"(The odometry pipeline, fed row by row or in bulk.

Odometry(config, t0=0.0, estimator="consensus", **options): config is a path
or a moa.Config; t0 (s) the first epoch's start; options as moa.odometry.
Feed inputs in time order; each call returns the steps that became ready, as
a dict of arrays like moa.odometry's (possibly empty).)")
      .def(py::init<const py::object&, double, const std::string&, const py::kwargs&>(),
           py::arg("config"), py::arg("t0") = 0.0, py::arg("estimator") = "consensus")
      .def("push", &PyOdometry::push, py::arg("t"), py::arg("sensor"), py::arg("dx"), py::arg("dy"),
           py::arg("squal") = py::none(), py::arg("flags") = 0,
           "A mice row: time (s), sensor (name or index), counts (sensor frame), squal (None or "
           "-1: absent), flags.")
      .def("push_rows", &PyOdometry::push_rows, py::arg("t"), py::arg("sensor"), py::arg("dx"),
           py::arg("dy"), py::arg("squal") = py::none(), py::arg("flags") = py::none(),
           "Mice rows in bulk: arrays of one length (sensor: indices or names; squal: -1 where "
           "absent).")
      .def("push_wheels", &PyOdometry::push_wheels, py::arg("t"), py::arg("vx"), py::arg("vy"),
           py::arg("omega"),
           "A wheel-odometry row: the twist (robot frame) averaged since the previous one, ending "
           "at t.")
      .def("push_fix", &PyOdometry::push_fix, py::arg("t"), py::arg("x"), py::arg("y"),
           py::arg("theta") = py::none(), py::arg("sx") = py::none(), py::arg("sy") = py::none(),
           "A camera fix captured at t: position (world frame, m), heading (rad), sd (m).")
      .def("finish", &PyOdometry::finish, py::arg("t_end"),
           "Ends the stream at t_end (the last row's time): the remaining steps.")
      .def_property_readonly("pose", &PyOdometry::pose, "(x, y, theta) of the last step.")
      .def_property_readonly("steps", &PyOdometry::steps, "Steps emitted so far.")
      .def_property_readonly("names", &PyOdometry::names);

  py::class_<io::RunSummary>(m, "RunSummary",
                             R"(What an odometry run did (runs/run_summary.hpp): the
"summary" of moa.odometry's result.)")
      .def_readonly("epochs", &io::RunSummary::epochs)
      .def_property_readonly(
          "epochs_by_source",
          [](const io::RunSummary& s) {
            py::dict d;
            for (std::size_t i = 0; i < io::kSourceCount; ++i)
              d[to_name(static_cast<Source>(i))] = s.epochs_by_source[i];
            return d;
          },
          "Epochs by the source of their twist: mice, wheels, hold.")
      .def_property_readonly(
          "sensor_epochs",
          [](const io::RunSummary& s) {
            py::dict d;
            for (std::size_t i = 0; i < io::kExclusionCount; ++i)
              d[to_name(static_cast<Exclusion>(i))] = s.sensor_epochs[i];
            return d;
          },
          "Sensor-epochs by what happened to the sensor: used, or the reason it was excluded.")
      .def_property_readonly("fixes",
                             [](const io::RunSummary& s) {
                               py::dict d;
                               d["applied"] = s.fixes.applied;
                               d["rejected"] = s.fixes.rejected;
                               d["too_old"] = s.fixes.too_old;
                               d["invalid"] = s.fixes.invalid;
                               return d;
                             })
      .def_readonly("gyro_epochs", &io::RunSummary::gyro_epochs,
                    "Epochs with a gyro reading (an imu row of diagnostics.csv).")
      .def_readonly("heading_from_gyro", &io::RunSummary::heading_from_gyro,
                    "Epochs whose heading (rotation) was the gyro's.")
      .def_property_readonly(
          "gyro",
          [](const io::RunSummary& s) -> py::object {
            if (!s.gyro) return py::none();
            py::dict d;
            d["bias"] = s.gyro->bias;
            d["bias_sd"] = s.gyro->bias_sd;
            d["scale"] = s.gyro->scale;
            d["scale_sd"] = s.gyro->scale_sd;
            d["latency"] = s.gyro->latency;
            d["latency_sd"] = s.gyro->latency_sd;
            return d;
          },
          "The gyro's calibration after the last epoch: bias, bias_sd (rad/s), scale, scale_sd, "
          "latency, latency_sd (s); None without a gyro.")
      .def_readonly("warnings", &io::RunSummary::warnings)
      .def_property_readonly("usable", &io::RunSummary::usable,
                             "At least one epoch, at most 1 % of them held.")
      .def("verdict", &io::RunSummary::verdict)
      .def("text", &io::RunSummary::text, "What `moa odometry` prints.");

  py::class_<io::CalibrationSummary>(m, "Calibration", R"(The result and report of moa.calibrate.)")
      .def_property_readonly("method",
                             [](const io::CalibrationSummary& s) { return to_name(s.method); })
      .def_property_readonly(
          "sensors",
          [](const io::CalibrationSummary& s) {
            py::list l;
            for (const auto& r : s.sensors) l.append(sensor_dict(r));
            return l;
          },
          R"(Per sensor: name, position (2,) m, yaw rad, scale (2,), mirrored, cpi (as
calibrated); sd_position, sd_yaw, sd_scale (1-sigma, 0 where kept);
estimated (which parameters were estimated, the observability report),
mirror_from_data, nominal (the config's mount), residual_rms (m/s, kimlee
and exact), push_misfit (m, guided), information_eigenvalues (exact).)")
      .def_property_readonly(
          "observability",
          [](const io::CalibrationSummary& s) {
            py::list l;
            for (const auto& r : s.sensors) {
              const py::dict d = sensor_dict(r);
              py::dict o;
              for (const char* key : {"name", "estimated", "information_eigenvalues"})
                o[key] = d[key];
              l.append(o);
            }
            return l;
          },
          R"(Per sensor: name, estimated (which parameters the data determined; the
others were kept at nominal) and information_eigenvalues (exact: of the
Fisher information in units of a generous mounting error, ascending; below 1
means not excited).)")
      .def_readonly("usable", &io::CalibrationSummary::usable,
                    "The solve converged and the data determined what the method estimates.")
      .def_property_readonly(
          "termination", [](const io::CalibrationSummary& s) { return to_name(s.termination); },
          "converged, not-converged, model-misfit, underdetermined or too-few-measurements.")
      .def_property_readonly("facts", [](const io::CalibrationSummary& s) { return s.facts; })
      .def_property_readonly("warnings", [](const io::CalibrationSummary& s) { return s.warnings; })
      .def_property_readonly(
          "config",
          [](const io::CalibrationSummary& s) {
            return Config{s.calibrated, "calibrated"};
          },
          "The calibrated config (a moa.Config).")
      .def(
          "to_yaml",
          [](const io::CalibrationSummary& s) { return io::format_config(s.calibrated); },
          "The calibrated config as YAML: what `moa calibrate --out` writes.")
      .def("brief_report", &io::CalibrationSummary::brief_report)
      .def("full_report", &io::CalibrationSummary::full_report,
           "The text report `moa calibrate` prints.")
      .def(
          "to_json", [](const io::CalibrationSummary& s) { return s.to_json(); },
          "The report as `moa calibrate --json` prints it (without \"out\").")
      .def("__repr__", &io::CalibrationSummary::brief_report);

  m.def("calibrate", &calibrate, py::arg("config"), py::arg("log_dir") = py::none(),
        py::arg("method") = "exact", R"(Runs `moa calibrate`: sensor mounts from a log.

method: exact (all extrinsics against wheels.csv), kimlee (positions, Kim &
Lee) or guided (log_dir None; push_x, push_y, spin recordings). Options, as
the command's flags: max_row_interval (s), min_interval (s), measurements;
guided: push_x, push_y, spin (paths), distance (m), turns, distance_sd (m),
turn_sd (rad), centre_sd (m), heading_sd (rad); exact: reference ("wheels" or
"camera": camera.csv with theta from motion capture, or positions only from a
ceiling camera; default wheels when the log has wheels.csv), max_offset (s,
the latency search's range), window (s, least window between fixes).
Returns a moa.Calibration; its config carries the latencies found.)");

  m.def("simulate", &simulate, py::arg("scenario"), py::arg("seed") = 1,
        py::arg("out") = py::none(), R"(Runs the simulator (`moa simulate`).

scenario: a built-in name (see moa.scenarios()) or a scenario YAML path.
With out, also writes the log there (the same records). Returns a dict:
mice (t, sensor, dx, dy, squal, flags, faults), wheels (t, vx, vy, omega),
imu (t, gz: the gyro's rows, what imu.csv gets; empty without a gyro), camera
(t, t_arrival, x, y, sigma, outlier), truth (t, x, y, theta, vx, vy, omega:
twist over the frame ending at t), config (nominal moa.Config), true_config,
names.)");

  m.def("scenarios", &sim::builtin_scenarios, "Names of the built-in scenarios.");

  m.def("evaluate", &evaluate, py::arg("truth"), py::arg("odometry"),
        R"(Max and RMS translation (m) and heading (rad) error against truth (`moa evaluate`).

truth, odometry: two paths (truth.csv, odometry.csv) or two dicts of arrays
with t, x, y, theta. Returns a dict: samples, outside_truth_span,
max_translation_m, rms_translation_m, max_heading_rad, rms_heading_rad,
final_translation_m, final_heading_rad (the last estimate's).)");
}
