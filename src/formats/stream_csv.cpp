#include "moa/formats/stream_csv.hpp"

#include <fmt/ostream.h>

namespace moa::io {

StreamCsvWriter::StreamCsvWriter(std::filesystem::path dir, std::string comment)
    : dir_(std::move(dir)), comment_(std::move(comment)) {}

void StreamCsvWriter::write(const WheelRow& r) {
  if (!wheels_) {
    wheels_ = std::make_unique<AtomicFile>(dir_ / "wheels.csv");
    fmt::print(wheels_->stream(), "# {}\nt,vx,vy,omega\n", comment_);
  }
  fmt::print(wheels_->stream(), "{},{},{},{}\n", r.t, r.twist.v.x(), r.twist.v.y(), r.twist.omega);
  ++wheel_rows_;
}

void StreamCsvWriter::write(const ImuRow& r) {
  if (!imu_) {
    imu_ = std::make_unique<AtomicFile>(dir_ / "imu.csv");
    fmt::print(imu_->stream(), "# {}\nt,gz\n", comment_);
  }
  fmt::print(imu_->stream(), "{},{}\n", r.t, r.gz);
  ++imu_rows_;
}

void StreamCsvWriter::write(const CameraFix& f) {
  if (!camera_) {
    camera_ = std::make_unique<AtomicFile>(dir_ / "camera.csv");
    fmt::print(camera_->stream(), "# {}\nt,x,y,theta,sx,sy\n", comment_);
  }
  std::ostream& out = camera_->stream();
  fmt::print(out, "{},{},{},", f.t, f.position.x(), f.position.y());
  if (f.theta) fmt::print(out, "{}", *f.theta);
  if (f.sigma) {
    fmt::print(out, ",{},{}\n", f.sigma->x(), f.sigma->y());
  } else {
    out << ",,\n";
  }
  ++fixes_;
}

void StreamCsvWriter::commit() {
  if (wheels_) wheels_->commit();
  if (imu_) imu_->commit();
  if (camera_) camera_->commit();
}

}  // namespace moa::io
