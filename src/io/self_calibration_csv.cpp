#include "moa/io/self_calibration_csv.hpp"

#include <fmt/format.h>

#include <cmath>
#include <optional>
#include <ostream>

#include "moa/io/atomic_file.hpp"

namespace moa::io {

struct SelfCalibrationCsvWriter::Impl {
  Impl(const std::filesystem::path& path, std::vector<std::string> sensor_names, SensorMask mask,
       double every)
      : file(path), names(std::move(sensor_names)), selected(mask), period(every) {
    file.stream() << "t,sensor,scale_x,scale_y,yaw_offset\n";
  }
  void rows(double t, const std::array<SelfCalibrationEstimate, kMaxSensors>& c) {
    for (std::size_t i = 0; i < names.size() && i < kMaxSensors; ++i) {
      if (!contains(selected, static_cast<int>(i))) continue;
      file.stream() << fmt::format("{},{},{},{},{}\n", t, names[i], c[i].scale_x, c[i].scale_y,
                                   c[i].yaw_offset);
    }
    written = t;
  }

  AtomicFile file;
  std::vector<std::string> names;
  SensorMask selected;
  double period;
  std::optional<double> first, written;
  double last_t = 0.0;
  std::array<SelfCalibrationEstimate, kMaxSensors> last{};
  bool any = false;
};

SelfCalibrationCsvWriter::SelfCalibrationCsvWriter(const std::filesystem::path& file,
                                                   std::vector<std::string> names,
                                                   SensorMask selected, double period)
    : impl_(std::make_unique<Impl>(file, std::move(names), selected, period)) {}

SelfCalibrationCsvWriter::~SelfCalibrationCsvWriter() = default;

void SelfCalibrationCsvWriter::write(const OdometryStep& step) {
  if (step.calibration == nullptr) return;
  Impl& m = *impl_;
  const double t = step.t();
  if (!m.first) m.first = t;
  m.last = *step.calibration;
  m.last_t = t;
  m.any = true;
  const double due = m.written ? std::floor((*m.written - *m.first) / m.period + 1e-9) + 1.0 : 0.0;
  if (!m.written || t - *m.first >= due * m.period - 1e-9) m.rows(t, m.last);
}

void SelfCalibrationCsvWriter::commit() {
  Impl& m = *impl_;
  if (m.any && (!m.written || *m.written != m.last_t)) m.rows(m.last_t, m.last);
  m.file.commit();
}

}  // namespace moa::io
