#include "moa/sim/log_writer.hpp"

#include <fmt/format.h>

#include <fcntl.h>
#include <stdio.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <memory>
#include <optional>
#include <random>
#include <string_view>
#include <system_error>
#include <vector>

#include "moa/formats/atomic_file.hpp"
#include "moa/formats/cleanup.hpp"
#include "moa/formats/config.hpp"
#include "moa/formats/error.hpp"
#include "moa/sim/fault_truth.hpp"

namespace moa::sim {
namespace {

// -0 prints as "-0"; a log should not carry that sign of rounding.
double tidy(double x) { return x + 0.0; }

// A CSV output: lines gathered in a buffer, flushed to an AtomicFile.
class CsvOut {
 public:
  CsvOut(const std::filesystem::path& file, std::string_view comment, std::string_view header)
      : file_(file) {
    fmt::format_to(std::back_inserter(buffer_), "# {}\n{}\n", comment, header);
  }
  template <class... Args>
  void line(fmt::format_string<Args...> format, Args&&... args) {
    fmt::format_to(std::back_inserter(buffer_), format, std::forward<Args>(args)...);
    buffer_.push_back('\n');
    ++rows_;
    if (buffer_.size() > (1u << 16)) flush();
  }
  void commit() {
    flush();
    file_.commit();
  }
  std::int64_t rows() const { return rows_; }

 private:
  void flush() {
    file_.stream().write(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
    buffer_.clear();
  }
  io::AtomicFile file_;
  fmt::memory_buffer buffer_;
  std::int64_t rows_ = 0;
};

class FileSink : public LogSink {
 public:
  FileSink(const Scenario& s, std::uint64_t seed, const std::filesystem::path& dir)
      : names_(s.nominal.names),
        comment_(fmt::format("moa simulate: scenario '{}', seed {} (log format v1)", s.name, seed)),
        mice_(dir / "mice.csv", comment_, "t,sensor,dx,dy,squal,flags"),
        faults_(dir / "faults.csv",
                comment_ +
                    "; fault truth per mice.csv row, bits: 1 tracking_loss, 2 liftoff, "
                    "4 dirty, 8 spikes, 16 stuck, 32 drift",
                "t,sensor,faults,faulty_frames,clean_dx,clean_dy"),
        truth_(dir / "truth.csv", comment_, "t,x,y,theta,vx,vy,omega"),
        fault_truth_(s),
        fault_json_(dir / "faults.json"),
        seed_(seed),
        imu_latency_(s.imu.latency) {
    if (s.drive.type != DriveType::kNone) {
      wheels_.emplace(dir / "wheels.csv", comment_, "t,vx,vy,omega");
    }
    if (s.imu.enabled) {
      imu_.emplace(dir / "imu.csv",
                   comment_ +
                       "; faults (moa extension): 1 where the gyro was stuck, saturated or "
                       "its bias had stepped",
                   "t,gz,faults");
    }
    if (s.camera.enabled) {
      camera_.emplace(dir / "camera.csv",
                      comment_ +
                          "; t is the stamp at arrival (the capture time plus camera.latency), "
                          "t_arrival the same (kept for older readers)",
                      s.camera.mode == CameraMode::kMocap ? "t,x,y,theta,sx,sy,t_arrival,outlier"
                                                          : "t,x,y,sx,sy,t_arrival,outlier");
    }
  }

  void mice(const MiceRecord& r) override {
    const std::string& name = names_[static_cast<std::size_t>(r.sensor)];
    const SensorRowOut& o = r.row;
    mice_.line("{},{},{},{},{},{}", r.t, name, o.counts.x(), o.counts.y(), o.squal, o.flags);
    faults_.line("{},{},{},{},{},{}", r.t, name, o.faults, o.faulty_frames, o.clean.x(),
                 o.clean.y());
    if (o.faults != 0) ++faulty_rows_;
    fault_truth_.mice(r);
  }
  void wheels(const WheelRecord& r) override {
    wheels_->line("{},{:.9g},{:.9g},{:.9g}", r.t, tidy(r.twist.v.x()), tidy(r.twist.v.y()),
                  tidy(r.twist.omega));
  }
  void imu(const ImuRecord& r) override {
    imu_->line("{},{:.9g},{}", r.t, tidy(r.gz), r.faulty ? 1 : 0);
    fault_truth_.imu(r, imu_start_);
    imu_start_ = r.t - imu_latency_;
  }
  void camera(const CameraFix& f) override {
    if (f.theta) {
      camera_->line("{},{:.9g},{:.9g},{:.9g},{},{},{:.9g},{}", f.t_arrival, tidy(f.position.x()),
                    tidy(f.position.y()), tidy(*f.theta), f.sigma, f.sigma, f.t_arrival,
                    f.outlier ? 1 : 0);
      return;
    }
    camera_->line("{},{:.9g},{:.9g},{},{},{:.9g},{}", f.t_arrival, tidy(f.position.x()),
                  tidy(f.position.y()), f.sigma, f.sigma, f.t_arrival, f.outlier ? 1 : 0);
  }
  void truth(const TruthRecord& r) override {
    truth_.line("{},{},{},{},{},{},{}", r.t, tidy(r.pose.t.x()), tidy(r.pose.t.y()),
                tidy(r.pose.theta), tidy(r.twist.v.x()), tidy(r.twist.v.y()), tidy(r.twist.omega));
  }

  LogSummary commit() {
    mice_.commit();
    faults_.commit();
    truth_.commit();
    if (wheels_) wheels_->commit();
    if (imu_) imu_->commit();
    if (camera_) camera_->commit();
    const std::string json = fault_truth_.json(seed_);
    fault_json_.stream().write(json.data(), static_cast<std::streamsize>(json.size()));
    fault_json_.commit();
    LogSummary s;
    s.mice_rows = mice_.rows();
    s.truth_rows = truth_.rows();
    s.wheel_rows = wheels_ ? wheels_->rows() : 0;
    s.camera_rows = camera_ ? camera_->rows() : 0;
    s.faulty_rows = faulty_rows_;
    return s;
  }

 private:
  const std::vector<std::string>& names_;
  std::string comment_;
  CsvOut mice_;
  CsvOut faults_;
  CsvOut truth_;
  std::optional<CsvOut> wheels_;
  std::optional<CsvOut> imu_;
  std::optional<CsvOut> camera_;
  std::int64_t faulty_rows_ = 0;
  FaultTruth fault_truth_;
  io::AtomicFile fault_json_;
  std::uint64_t seed_;
  double imu_latency_;
  double imu_start_ = 0.0;  ///< s, true start of the next gyro row
};

// The files a run writes; a directory holding only these, with a mice.csv
// that says it was simulated, is a previous run that may be replaced.
constexpr std::array<std::string_view, 10> kLogFiles{
    "mice.csv",   "wheels.csv",  "imu.csv",    "camera.csv",      "truth.csv",
    "faults.csv", "faults.json", "robot.yaml", "robot.true.yaml", "scenario.yaml"};

bool is_previous_run(const std::filesystem::path& dir, std::string& foreign) {
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (std::find(kLogFiles.begin(), kLogFiles.end(), name) == kLogFiles.end() ||
        !entry.is_regular_file()) {
      foreign = name;
      return false;
    }
  }
  if (ec) {
    foreign = ec.message();
    return false;
  }
  std::ifstream mice(dir / "mice.csv");
  std::string first;
  std::getline(mice, first);
  foreign = "mice.csv";
  return first.starts_with("# moa simulate:");
}

// Where a run is written before it is moved into place, beside the target.
std::filesystem::path temporary_dir_beside(const std::filesystem::path& dir) {
  std::random_device random;
  const auto tag = (static_cast<std::uint64_t>(random()) << 32) ^ random();
  return dir.parent_path() / fmt::format(".{}.{:016x}.tmp", dir.filename().string(), tag);
}

}  // namespace

LogSummary write_log(const Scenario& scenario, std::uint64_t seed, const std::filesystem::path& out,
                     const Progress& progress, std::string_view scenario_text) {
  std::error_code ec;
  // Absolute, so that "run/", "." or ".." have a name and a parent to write beside.
  std::filesystem::path dir = std::filesystem::absolute(out, ec).lexically_normal();
  if (ec) throw io::Error(fmt::format("{}: {}", out.string(), ec.message()));
  if (!dir.has_filename()) dir = dir.parent_path();
  if (dir == dir.root_path()) {
    throw io::Error(fmt::format("{}: cannot write a log over the root directory", out.string()));
  }
  // Refused before the run, not after it: an empty or new directory, or a
  // previous run to be replaced whole (never a mix of two runs' files).
  bool replace = false;
  if (std::filesystem::exists(dir, ec)) {
    if (!std::filesystem::is_directory(dir, ec)) {
      throw io::Error(fmt::format("{}: exists and is not a directory", dir.string()));
    }
    if (!std::filesystem::is_empty(dir, ec)) {
      std::string foreign;
      if (!is_previous_run(dir, foreign)) {
        throw io::Error(fmt::format(
            "{}: not empty and not a log written by moa simulate ('{}'); give an empty or new "
            "directory",
            dir.string(), foreign));
      }
      replace = true;
    }
  }
  if (dir.has_parent_path()) std::filesystem::create_directories(dir.parent_path(), ec);
  const std::filesystem::path temp = temporary_dir_beside(dir);
  if (!std::filesystem::create_directory(temp, ec) || ec) {
    throw io::Error(fmt::format("{}: cannot create the output directory{}", dir.string(),
                                ec ? ": " + ec.message() : ""));
  }
  // Removed on an error (below) and on SIGINT/SIGTERM (its files first).
  std::vector<io::TemporaryPath> registered;
  registered.emplace_back(temp);
  for (const auto name : kLogFiles) registered.emplace_back(temp / name);
  bool placed = false;
  struct RemoveUnlessPlaced {
    const std::filesystem::path& temp;
    const bool& placed;
    ~RemoveUnlessPlaced() {
      std::error_code ignored;
      if (!placed) std::filesystem::remove_all(temp, ignored);
    }
  } cleanup{temp, placed};

  LogSummary summary;
  {
    FileSink sink(scenario, seed, temp);
    simulate(scenario, seed, sink, progress);
    // The configs are written first among the commits' files: a reader that
    // finds a log directory finds its config in it.
    io::write_config(scenario.nominal, temp / "robot.yaml");
    io::write_config(scenario.truth, temp / "robot.true.yaml");
    if (!scenario_text.empty()) {
      io::AtomicFile text(temp / "scenario.yaml");
      text.stream().write(scenario_text.data(), static_cast<std::streamsize>(scenario_text.size()));
      text.commit();
    }
    summary = sink.commit();
  }
  if (!std::filesystem::exists(dir, ec)) {
    std::filesystem::rename(temp, dir, ec);
    if (ec) throw io::Error(fmt::format("{}: cannot write ({})", dir.string(), ec.message()));
    placed = true;
  } else if (!replace) {
    // Into the empty directory file by file (it stays the same directory,
    // which a shell may be in), mice.csv first: a run stopped half way in
    // is recognised as a previous run, and replaced by the next.
    for (const auto name : kLogFiles) {
      if (!std::filesystem::exists(temp / name, ec)) continue;
      std::filesystem::rename(temp / name, dir / name, ec);
      if (ec) {
        throw io::Error(fmt::format("{}: cannot write ({})", (dir / name).string(), ec.message()));
      }
    }
  } else {
    // The new run and the old swap places at once; the old is then removed.
    if (::renameat2(AT_FDCWD, temp.c_str(), AT_FDCWD, dir.c_str(), RENAME_EXCHANGE) != 0) {
      throw io::Error(fmt::format("{}: cannot replace the previous run ({})", dir.string(),
                                  std::strerror(errno)));
    }
    std::filesystem::remove_all(temp, ec);
    placed = true;
  }
  summary.frames = scenario.frame_count();
  summary.duration = static_cast<double>(summary.frames) / scenario.sensor_model.frame_rate;
  return summary;
}

}  // namespace moa::sim
