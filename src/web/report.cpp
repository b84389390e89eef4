// build_report: reads the run's files and reduces them to what the page
// plots. The odometry is read twice (streamed): the first pass checks it
// and finds its time span, which fixes the bins the second pass fills.
#include "moa/web/report.hpp"

#include "moa/formats/odometry_csv.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string_view>

#include "moa/formats/atomic_file.hpp"
#include "moa/formats/csv.hpp"
#include "moa/formats/diagnostics_csv.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/log.hpp"
#include "moa/formats/self_calibration_csv.hpp"

namespace moa::io {
namespace {

namespace fs = std::filesystem;

/// Timeline states by name; "used" is state 0.
class StateTable {
 public:
  StateTable() { intern("used"); }
  int intern(std::string_view name) {
    const auto found = ids_.find(name);
    if (found != ids_.end()) return found->second;
    const int id = static_cast<int>(names_.size());
    names_.emplace_back(name);
    ids_.emplace(std::string(name), id);
    return id;
  }
  const std::vector<std::string>& names() const { return names_; }

 private:
  std::vector<std::string> names_;
  std::map<std::string, int, std::less<>> ids_;
};

constexpr int kUsed = 0;

std::string joined_names(const RobotConfig& config) {
  std::string out;
  for (const auto& name : config.names) out += (out.empty() ? "" : ", ") + name;
  return out;
}

/// One row of odometry.csv with the selection columns decoded.
struct OdometryRecord {
  double t = 0.0;
  Pose2 pose;
  Twist2 twist;
  int source = -1;                       ///< state id, -1 without a `source` column
  std::array<int, kMaxSensors> state{};  ///< per sensor; -1 when not listed
};

/// odometry.csv through the typed reader (io/odometry_csv.hpp), each
/// sensor's state and the source as timeline state ids.
class OdometryFile {
 public:
  OdometryFile(const fs::path& file, const RobotConfig& config, std::string config_path,
               StateTable& states)
      : reader_(file, config, std::move(config_path)), n_(config.array.size()), states_(states) {}

  bool has_selection() const { return reader_.has_selection(); }
  const std::string& file() const { return reader_.file(); }

  bool next() {
    const auto row = reader_.next();
    if (!row) return false;
    r_.t = row->t;
    r_.pose = row->pose;
    r_.twist = row->twist;
    r_.state.fill(-1);
    for (int i = 0; i < n_; ++i) {
      const auto u = static_cast<std::size_t>(i);
      if (contains(row->used, i)) {
        r_.state[u] = kUsed;
      } else if (contains(row->listed, i)) {
        r_.state[u] = states_.intern(describe_exclusion(row->excluded[u], row->noise_flags[u]));
      }
    }
    r_.source = row->source ? states_.intern(to_name(*row->source)) : -1;
    row_ = *row;
    return true;
  }
  const OdometryRecord& record() const { return r_; }
  const OdometryRow& row() const { return row_; }

 private:
  OdometryCsvReader reader_;
  int n_;
  StateTable& states_;
  OdometryRecord r_;
  OdometryRow row_;
};

/// The calibrated config's sensors in the nominal config's order; the two
/// must name the same sensors.
RobotConfig matched_calibration(const RobotConfig& nominal, const std::string& nominal_path,
                                const RobotConfig& calibrated, const std::string& path) {
  for (const auto& name : calibrated.names) {
    if (!nominal.index_of(name)) {
      throw Error(fmt::format("{}: sensor '{}' is not in {} ({})", path, name, nominal_path,
                              joined_names(nominal)));
    }
  }
  RobotConfig out = calibrated;  // the rest of the config (imu, latencies) as calibrated
  out.names.clear();
  std::vector<SensorMount> mounts;
  for (const auto& name : nominal.names) {
    const auto index = calibrated.index_of(name);
    if (!index) throw Error(fmt::format("{}: has no sensor '{}' of {}", path, name, nominal_path));
    out.names.push_back(name);
    mounts.push_back(calibrated.array[*index]);
  }
  out.array = SensorArray(std::move(mounts));
  return out;
}

/// Every k-th element and the last, so that at most about `max_points` remain.
template <class T>
std::vector<T> decimated(const std::vector<T>& all, std::size_t max_points) {
  if (all.size() <= max_points || max_points < 2) return all;
  const std::size_t stride = (all.size() + max_points - 2) / (max_points - 1);
  std::vector<T> out;
  for (std::size_t k = 0; k < all.size(); k += stride) out.push_back(all[k]);
  if ((all.size() - 1) % stride != 0) out.push_back(all.back());
  return out;
}

/// Fills the timeline: per bin, each row's most frequent state; adjacent
/// bins with the same state merge into one segment.
class TimelineBuilder {
 public:
  TimelineBuilder(int rows, int states)
      : rows_(rows),
        states_(states),
        counts_(static_cast<std::size_t>(rows * states), 0),
        open_(static_cast<std::size_t>(rows)) {}

  void count(int row, int state) { ++counts_[index(row, state)]; }

  /// Closes the bin [t0, t1] that the counts so far belong to.
  void close_bin(double t0, double t1) {
    for (int row = 0; row < rows_; ++row) {
      std::size_t total = 0, best = 0;
      int best_state = -1;
      for (int s = 0; s < states_; ++s) {
        const std::size_t c = counts_[index(row, s)];
        total += c;
        if (c > best) best = c, best_state = s;
      }
      if (total == 0) continue;
      Open& open = open_[static_cast<std::size_t>(row)];
      if (open.segment && open.segment->state == best_state) {
        open.segment->t1 = t1;
      } else {
        flush(open);
        open.segment = TimelineSegment{row, best_state, t0, t1, 1.0};
      }
      open.dominant += best;
      open.total += total;
    }
    std::fill(counts_.begin(), counts_.end(), 0);
  }

  std::vector<TimelineSegment> finish() {
    for (auto& open : open_) flush(open);
    std::sort(segments_.begin(), segments_.end(), [](const auto& a, const auto& b) {
      return a.row != b.row ? a.row < b.row : a.t0 < b.t0;
    });
    return std::move(segments_);
  }

 private:
  struct Open {
    std::optional<TimelineSegment> segment;
    std::size_t dominant = 0, total = 0;
  };
  std::size_t index(int row, int state) const {
    return static_cast<std::size_t>(row * states_ + state);
  }
  void flush(Open& open) {
    if (!open.segment) return;
    open.segment->share = static_cast<double>(open.dominant) / static_cast<double>(open.total);
    segments_.push_back(*open.segment);
    open = Open{};
  }

  int rows_, states_;
  std::vector<std::size_t> counts_;
  std::vector<Open> open_;
  std::vector<TimelineSegment> segments_;
};

void read_mice(const ReportInputs& inputs, const RobotConfig& config,
               std::vector<SensorSummary>& sensors) {
  MiceReader mice(inputs.log, config);
  while (const auto row = mice.next()) {
    SensorSummary& s = sensors[static_cast<std::size_t>(row->sensor)];
    ++s.mice_rows;
    if (row->flags & kFlagLift) ++s.lift_rows;
    if (row->flags & kFlagOverflow) ++s.overflow_rows;
    if (row->squal) s.min_squal = std::min<int>(s.min_squal.value_or(255), *row->squal);
  }
}

}  // namespace

ReportModel build_report(const ReportInputs& inputs, const ReportOptions& options) {
  if (options.max_points < 2) throw Error("report: max_points must be at least 2");
  ReportModel m;
  m.inputs = inputs;
  m.config = read_config(inputs.config);
  const std::string config_path = inputs.config.string();
  const int n = m.config.array.size();
  m.title = inputs.title;
  if (m.title.empty()) {
    fs::path log = fs::absolute(inputs.log).lexically_normal();
    if (log.filename().empty()) log = log.parent_path();
    m.title = "moa report: " + log.filename().string();
  }
  if (inputs.calibration) {
    m.calibrated = matched_calibration(m.config, config_path, read_config(*inputs.calibration),
                                       inputs.calibration->string());
  }

  if (inputs.self_calibration) {
    const std::string path = inputs.self_calibration->string();
    std::vector<ScaleSeries> all(static_cast<std::size_t>(n));
    for (const auto& row : read_self_calibration_csv(*inputs.self_calibration)) {
      const auto index = m.config.index_of(row.sensor);
      if (!index) {
        throw Error(fmt::format("{}: sensor '{}' is not in {} ({})", path, row.sensor, config_path,
                                joined_names(m.config)));
      }
      ScaleSeries& s = all[static_cast<std::size_t>(*index)];
      s.t.push_back(row.t);
      s.scale_x.push_back(row.filter.scale_x);
      s.scale_y.push_back(row.filter.scale_y);
      s.yaw_offset.push_back(row.filter.yaw_offset);
    }
    for (auto& s : all) {
      m.self_calibration.push_back(
          {decimated(s.t, options.max_points), decimated(s.scale_x, options.max_points),
           decimated(s.scale_y, options.max_points), decimated(s.yaw_offset, options.max_points)});
    }
  }

  if (inputs.diagnostics) {
    GyroCounts g;
    for (const auto& row : read_diagnostics_csv(*inputs.diagnostics)) {
      if (row.source == "prior") ++g.epochs;
      if (row.source != "imu") continue;
      ++g.readings;
      if (row.fused) ++g.heading;
      if (row.reason == "saturated") ++g.saturated;
      if (row.reason == "inconsistent") ++g.inconsistent;
      if (row.test_ratio > 1.0) ++g.over_gate;
      if (!std::isnan(row.test_ratio)) g.max_test = std::max(g.max_test, row.test_ratio);
      if (row.bias) g.bias = row.bias, g.scale = row.scale;
    }
    m.gyro = g;
  }

  std::error_code ec;
  m.has_imu = fs::exists(inputs.log / "imu.csv", ec);
  if (!fs::exists(inputs.log, ec)) {
    throw Error(fmt::format("{}: no such log directory", inputs.log.string()));
  }
  m.sensors.resize(static_cast<std::size_t>(n));
  read_mice(inputs, m.config, m.sensors);

  std::vector<StampedPose> truth;
  if (inputs.truth) {
    for (const auto& row : read_all<TruthRow>(*inputs.truth)) truth.push_back({row.t, row.pose});
    if (truth.size() < 2) {
      throw Error(fmt::format("{}: needs at least two rows", inputs.truth->string()));
    }
  }
  // --log may also name mice.csv itself, as for `moa odometry`.
  const fs::path log_dir = fs::is_directory(inputs.log, ec) ? inputs.log : inputs.log.parent_path();
  const fs::path camera_file = log_dir / "camera.csv";
  if (fs::exists(camera_file, ec)) {
    std::vector<Eigen::Vector2d> fixes;
    for (const auto& row : read_all<CameraRow>(camera_file)) fixes.push_back(row.position);
    m.camera_rows = fixes.size();
    m.camera = decimated(fixes, options.max_points);
  }

  // Pass 1: check every row, find the time span and every state name.
  StateTable states;
  for (const char* source : {"mice", "wheels", "hold"}) states.intern(source);
  {
    OdometryFile odometry(inputs.odometry, m.config, config_path, states);
    m.has_selection = odometry.has_selection();
    while (odometry.next()) {
      const OdometryRecord& r = odometry.record();
      if (m.epochs == 0) m.t_first = r.t;
      m.t_last = r.t;
      ++m.epochs;
      m.summary.add(odometry.row(), n);
      for (int i = 0; i < n && m.has_selection; ++i) {
        if (r.state[static_cast<std::size_t>(i)] == -1) states.intern("absent");
      }
    }
    if (m.epochs == 0) throw Error(fmt::format("{}: has no rows", odometry.file()));
  }
  m.states = states.names();
  const int state_count = static_cast<int>(m.states.size());
  for (auto& s : m.sensors) s.excluded.assign(m.states.size(), 0);
  m.sources.assign(m.states.size(), 0);

  // Pass 2: fill the bins. The first row is a bin of its own (the start).
  const std::size_t bin_count = options.max_points - 1;
  const double width = (m.t_last - m.t_first) / static_cast<double>(bin_count);
  const auto bin_of = [&](double t) {
    if (!(width > 0.0)) return std::size_t{0};
    const double b = std::floor((t - m.t_first) / width);
    return std::min(bin_count - 1, static_cast<std::size_t>(std::max(b, 0.0)));
  };
  std::vector<Eigen::Matrix<double, 2, 3>> point_jacobians;
  for (int i = 0; i < n; ++i) point_jacobians.push_back(m.config.array[i].point_jacobian());

  TimelineBuilder timeline(n + 1, state_count);
  std::optional<TrajectoryErrorAccumulator> accumulator;
  if (!truth.empty()) accumulator.emplace(truth);
  OdometryFile odometry(inputs.odometry, m.config, config_path, states);
  std::optional<std::size_t> open_bin;
  ReportBin bin;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const auto reset = [&](ReportBin& b) {
    b.translation_error = b.heading_error = nan;
    b.speed.fill(0.0);
  };
  const auto bin_start = [&](std::size_t b) { return m.t_first + width * static_cast<double>(b); };
  // A bin that ends at the first row's time repeats the start: it replaces it.
  const auto push_bin = [&m](const ReportBin& b) {
    if (!m.bins.empty() && m.bins.back().t == b.t) {
      m.bins.back() = b;
    } else {
      m.bins.push_back(b);
    }
  };
  std::optional<Pose2> previous;
  std::size_t row_index = 0;
  while (odometry.next()) {
    const OdometryRecord& r = odometry.record();
    if (static_cast<int>(states.names().size()) != state_count) {
      // A state that pass 1 did not see: the file is not what it was.
      throw Error(fmt::format("{}: changed while it was read", odometry.file()));
    }
    const std::size_t b = bin_of(r.t);
    if (open_bin && *open_bin != b) {
      push_bin(bin);
      timeline.close_bin(bin_start(*open_bin), bin_start(*open_bin + 1));
    }
    if (!open_bin || *open_bin != b) {
      open_bin = b;
      reset(bin);
    }
    bin.t = r.t;
    bin.pose = r.pose;
    ReportBin own;  // the first row's bin
    reset(own);
    own.t = r.t;
    own.pose = r.pose;
    ReportBin* targets[2] = {&bin, row_index == 0 ? &own : nullptr};

    if (accumulator) {
      accumulator->add(r.t, r.pose);
      if (const auto truth_pose = interpolate(truth, r.t)) {
        const double dp = (r.pose.t - truth_pose->t).norm();
        const double dh = std::abs(wrap_angle(r.pose.theta - truth_pose->theta));
        for (ReportBin* target : targets) {
          if (!target) continue;
          target->translation_error =
              std::isnan(target->translation_error) ? dp : std::max(target->translation_error, dp);
          target->heading_error =
              std::isnan(target->heading_error) ? dh : std::max(target->heading_error, dh);
        }
      }
    }
    for (int i = 0; i < n; ++i) {
      const auto u = static_cast<std::size_t>(i);
      const double s = (point_jacobians[u] * r.twist.vector()).norm();
      for (ReportBin* target : targets) {
        if (target) target->speed[u] = std::max(target->speed[u], s);
      }
      SensorSummary& summary = m.sensors[u];
      summary.max_speed = std::max(summary.max_speed, s);
      const auto& rated = m.config.array[i].max_speed;
      if (rated && s > *rated) ++summary.over_rated;
      if (m.has_selection) {
        const int state = r.state[u] == -1 ? states.intern("absent") : r.state[u];
        if (state >= state_count) {
          throw Error(fmt::format("{}: changed while it was read", odometry.file()));
        }
        timeline.count(i, state);
        if (state == kUsed) {
          ++summary.used;
        } else {
          ++summary.excluded[static_cast<std::size_t>(state)];
        }
      }
    }
    if (r.source >= 0) {
      timeline.count(n, r.source);
      ++m.sources[static_cast<std::size_t>(r.source)];
    }
    if (row_index == 0) m.bins.push_back(own);
    if (previous) m.distance += (r.pose.t - previous->t).norm();
    previous = r.pose;
    m.final_pose = r.pose;
    ++row_index;
  }
  if (open_bin) {
    push_bin(bin);
    timeline.close_bin(bin_start(*open_bin), bin_start(*open_bin + 1));
  }
  m.timeline = timeline.finish();
  if (accumulator) {
    m.errors = accumulator->result();
    if (m.errors->samples == 0) {
      throw Error(fmt::format("{}: no row lies within the time span of {}",
                              inputs.odometry.string(), inputs.truth->string()));
    }
    m.floor = quantisation_floor(m.config.array, truth);
    m.truth = decimated(truth, options.max_points);
  }
  return m;
}

void write_report(const ReportInputs& inputs, const fs::path& out, const ReportOptions& options) {
  const std::string page = render_report(build_report(inputs, options));
  AtomicFile file(out);
  file.stream() << page;
  file.commit();
}

}  // namespace moa::io
