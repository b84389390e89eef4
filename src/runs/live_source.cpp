#include "moa/runs/live_source.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>

#include "moa/formats/error.hpp"
#include "moa/runs/odometry_run.hpp"

namespace moa::io {

LiveSource open_live_source(const LiveSourceSpec& spec, const RobotConfig& config,
                            const std::string& config_path, const LiveHooks& hooks) {
  const int given =
      !spec.mice.empty() + !spec.serial.empty() + !spec.otos.empty() + !spec.replay.empty();
  if (given != 1) {
    throw Error(fmt::format(
        "a live source is one of: mice (evdev), a serial port, OTOS units, a log to replay ({} "
        "given)",
        given));
  }
  LiveSource s;
  if (!spec.mice.empty()) {
    if (static_cast<int>(spec.mice.size()) < config.array.size()) {
      hooks.warning(fmt::format("{} of the {} sensors of {} have a mouse; the others read as still",
                                spec.mice.size(), config.array.size(), config_path));
    }
    auto reader = std::make_unique<EvdevReader>(spec.mice, spec.evdev, hooks);
    s.evdev = reader.get();
    s.source = std::move(reader);
    s.where = "mice";
    s.mice = static_cast<int>(spec.mice.size());
    s.origin = fmt::format("{} mice (evdev)", spec.mice.size());
  } else if (!spec.serial.empty()) {
    auto reader = std::make_unique<SerialReader>(spec.serial, config, spec.serial_options, hooks);
    s.serial = reader.get();
    s.gyro = reader.get();
    s.source = std::move(reader);
    s.where = spec.serial;
    s.origin = spec.serial;
  } else if (!spec.otos.empty()) {
    if (static_cast<int>(spec.otos.size()) < config.array.size()) {
      hooks.warning(
          fmt::format("{} of the {} sensors of {} have an OTOS unit; the others read as still",
                      spec.otos.size(), config.array.size(), config_path));
    }
    auto reader = std::make_unique<OtosReader>(spec.otos, config, spec.otos_options, hooks);
    s.otos = reader.get();
    s.gyro = reader.get();
    s.source = std::move(reader);
    s.where = spec.otos.size() == 1 ? fmt::format("OTOS {}", spec.otos[0].name) : "OTOS units";
    s.origin =
        fmt::format("{} OTOS unit{} (i2c-dev)", spec.otos.size(), spec.otos.size() == 1 ? "" : "s");
  } else {
    auto reader = std::make_unique<ReplayReader>(spec.replay, config, spec.replay_options, hooks);
    s.replay = reader.get();
    s.source = std::move(reader);
    s.where = spec.replay;
    s.origin = fmt::format("a replay of {}", spec.replay);
  }
  return s;
}

std::vector<std::filesystem::path> live_source_files(const LiveSourceSpec& spec) {
  std::vector<std::filesystem::path> files;
  for (const auto& device : spec.mice) files.push_back(device.path);
  if (!spec.serial.empty()) files.emplace_back(spec.serial);
  for (const auto& unit : spec.otos) files.push_back(unit.bus.path);
  if (!spec.replay.empty()) {
    const auto log = resolve_log(spec.replay).files();
    files.insert(files.end(), log.begin(), log.end());
  }
  return files;
}

std::string LiveSource::alive(const RobotConfig& config) const {
  if (evdev) return fmt::format("mice {}/{} alive", evdev->alive(), mice);
  if (serial) {
    const bool fresh = serial->seconds_since_data() < 1.0;
    return fmt::format("sensors {}/{} alive, {} frames lost",
                       fresh ? serial->hello().names.size() : 0, config.names.size(),
                       serial->stats().lost_frames);
  }
  if (otos) return fmt::format("OTOS {}/{} answering", otos->answering(), otos->units());
  return fmt::format("replay, {} rows", replay ? replay->rows() : 0);
}

LiveRunSource::LiveRunSource(FrameSource& frames, int sensors, std::string where,
                             std::function<bool()> stop)
    : frames_(frames),
      sensors_(sensors),
      where_(std::move(where)),
      stop_(std::move(stop)),
      t0_(frames.start_time()) {}

void LiveRunSource::add_streams(StreamLineReader& streams, double speed) {
  streams_ = &streams;
  speed_ = speed;
  streams.set_source_clock({t0_, std::chrono::steady_clock::now(), speed});
}

double LiveRunSource::start_time() { return t0_; }

std::string LiveRunSource::where() const {
  if (from_log_ != nullptr && *from_log_) return (*from_log_)->string();
  return from_streams_ ? fmt::format("{} (streams)", where_) : where_;
}

void LiveRunSource::add_gyro(GyroStream& gyro) { gyro_serial_ = &gyro; }

void LiveRunSource::add_log(LogStreams& log, const LogFiles& files) {
  log_ = &log;
  log_files_ = &files;
  if (log.camera) log_fix_ = log.camera->next();
  if (log.wheels) log_wheel_ = log.wheels->next();
  if (log.imu) log_gyro_ = log.imu->next();
}

void LiveRunSource::take_gyro() {
  if (gyro_serial_ == nullptr) return;
  // The reader holds a window's rows for its sample only once it has seen
  // the gyro: a sample whose rows went out before it (the first) is stamped
  // just after them, so that a replay feeds it where this run did.
  const double after = std::nextafter(t_last_, std::numeric_limits<double>::infinity());
  for (const GyroSample& g : gyro_serial_->take_gyro()) {
    serial_gyro_.push_back(ImuRow{g.t > t_last_ ? g.t : after, g.gz});
  }
}

void LiveRunSource::take_streams() {
  if (streams_ == nullptr) return;
  arrived_.clear();
  streams_->take(arrived_);
  // Each stream in time order: a line whose own t is before its stream's
  // last row's is dropped and counted (the pipeline would refuse it and
  // end the run). A line is fed before the first mice row at or after its
  // t and recorded there, so that a replay feeds it where this run did: a
  // line stamped at arrival is stamped later than the last mice row handed
  // out (and than its stream's last row), and a line whose own t is
  // already past (it arrived late) is raised to just after that mice row.
  const double after = std::nextafter(t_last_, std::numeric_limits<double>::infinity());
  const auto admit = [&](auto& row, const StreamRow& s, StreamOrder& last, auto& queue) {
    if (s.stamped && row.t < last.own) {
      ++dropped_;
      return;
    }
    if (queue.size() >= kMaxHeldRows) {
      ++overflow_;
      return;
    }
    const double estimate =
        t_ref_ + speed_ * std::chrono::duration<double>(s.arrival - arrival_ref_).count();
    const double own = s.stamped ? row.t : std::max({estimate, after, last.own});
    row.t = std::max({own, after, last.fed});
    last = {own, row.t};
    queue.push_back(row);
  };
  for (StreamRow& s : arrived_) {
    if (auto* w = std::get_if<WheelRow>(&s.row)) {
      admit(*w, s, wheel_order_, wheels_);
    } else if (auto* g = std::get_if<ImuRow>(&s.row)) {
      admit(*g, s, gyro_order_, gyro_);
    } else {
      admit(std::get<CameraFix>(s.row), s, fix_order_, fixes_);
    }
  }
}

const InputRow* LiveRunSource::next() {
  from_streams_ = false;
  from_log_ = nullptr;
  if (started_ == 0) {
    t_last_ = t_ref_ = t0_;
    arrival_ref_ = std::chrono::steady_clock::now();
  }
  if (started_ < sensors_) {
    SensorRow start;
    start.t = t_last_;
    start.sensor = started_++;
    row_ = start;
    return &row_;
  }
  if (!pending_ && !ended_) {
    if (stop_ && stop_()) {
      ended_ = true;
    } else if (auto row = frames_.next()) {
      pending_ = *row;
      t_ref_ = row->t;
      arrival_ref_ = std::chrono::steady_clock::now();
      if (streams_ != nullptr) streams_->set_source_clock({t_ref_, arrival_ref_, speed_});
    } else {
      ended_ = true;
    }
    take_streams();
    take_gyro();
  }
  const double limit = ended_ ? t_last_ : pending_->t;
  // A row due from the first source that has one, in this order: fixes
  // (streamed, then the replayed log's), wheels (the same), the serial
  // device's gyro, the replayed log's gyro, the streamed gyro.
  const auto take = [&](auto& queue, std::size_t* streamed) {
    if (queue.empty() || queue.front().t > limit) return false;
    row_ = queue.front();
    queue.pop_front();
    if (streamed != nullptr) {
      from_streams_ = true;
      ++*streamed;
    }
    return true;
  };
  // The replayed log's rows, read as they fall due.
  const auto take_log = [&](auto& next, auto& reader, const auto& file) {
    if (!next || next->t > limit) return false;
    if constexpr (std::is_same_v<std::decay_t<decltype(*next)>, CameraRow>) {
      row_ = CameraFix{next->t, next->position, next->theta, next->sigma};
    } else {
      row_ = *next;
    }
    next = reader->next();
    from_log_ = &file;
    return true;
  };
  if (take(fixes_, &streamed_.fixes)) return &row_;
  if (log_ != nullptr && take_log(log_fix_, log_->camera, log_files_->camera)) return &row_;
  if (take(wheels_, &streamed_.wheels)) return &row_;
  if (log_ != nullptr && take_log(log_wheel_, log_->wheels, log_files_->wheels)) return &row_;
  if (take(serial_gyro_, nullptr)) return &row_;
  if (log_ != nullptr && take_log(log_gyro_, log_->imu, log_files_->imu)) return &row_;
  if (take(gyro_, &streamed_.imu)) return &row_;
  if (ended_) return nullptr;
  row_ = *pending_;
  t_last_ = pending_->t;
  arrival_last_ = arrival_ref_;
  pending_.reset();
  return &row_;
}

}  // namespace moa::io
