#include "moa/sim/log_writer.hpp"

#include <fmt/format.h>

#include <memory>
#include <optional>
#include <system_error>

#include "moa/io/atomic_file.hpp"
#include "moa/io/config.hpp"
#include "moa/io/error.hpp"

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
                    "4 dirty, 8 spikes, 16 stuck",
                "t,sensor,faults,faulty_frames,clean_dx,clean_dy"),
        truth_(dir / "truth.csv", comment_, "t,x,y,theta,vx,vy,omega") {
    if (s.drive.type != DriveType::kNone) {
      wheels_.emplace(dir / "wheels.csv", comment_, "t,vx,vy,omega");
    }
    if (s.camera.enabled) {
      camera_.emplace(dir / "camera.csv",
                      comment_ + "; t is the capture time, t_arrival when the fix arrived",
                      "t,x,y,sx,sy,t_arrival,outlier");
    }
  }

  void mice(const MiceRecord& r) override {
    const std::string& name = names_[static_cast<std::size_t>(r.sensor)];
    const SensorRowOut& o = r.row;
    mice_.line("{},{},{},{},{},{}", r.t, name, o.counts.x(), o.counts.y(), o.squal, o.flags);
    faults_.line("{},{},{},{},{},{}", r.t, name, o.faults, o.faulty_frames, o.clean.x(),
                 o.clean.y());
    if (o.faults != 0) ++faulty_rows_;
  }
  void wheels(const WheelRecord& r) override {
    wheels_->line("{},{:.9g},{:.9g},{:.9g}", r.t, tidy(r.twist.v.x()), tidy(r.twist.v.y()),
                  tidy(r.twist.omega));
  }
  void camera(const CameraFix& f) override {
    camera_->line("{},{:.9g},{:.9g},{},{},{:.9g},{}", f.t, tidy(f.position.x()),
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
    if (camera_) camera_->commit();
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
  std::optional<CsvOut> camera_;
  std::int64_t faulty_rows_ = 0;
};

}  // namespace

LogSummary write_log(const Scenario& scenario, std::uint64_t seed, const std::filesystem::path& dir,
                     const Progress& progress) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir)) {
    throw io::Error(fmt::format("{}: cannot create the output directory{}", dir.string(),
                                ec ? ": " + ec.message() : ""));
  }
  FileSink sink(scenario, seed, dir);
  simulate(scenario, seed, sink, progress);
  // The configs are written first among the commits' files: a reader that
  // finds a log directory finds its config in it.
  io::write_config(scenario.nominal, dir / "robot.yaml");
  io::write_config(scenario.truth, dir / "robot.true.yaml");
  LogSummary summary = sink.commit();
  summary.frames = scenario.frame_count();
  summary.duration = static_cast<double>(summary.frames) / scenario.sensor_model.frame_rate;
  return summary;
}

}  // namespace moa::sim
