#include "moa/formats/self_calibration_csv.hpp"

#include <fmt/format.h>

#include <cmath>
#include <optional>
#include <ostream>

#include "moa/formats/atomic_file.hpp"
#include "moa/formats/csv.hpp"

namespace moa::io {

struct SelfCalibrationCsvWriter::Impl {
  Impl(const std::filesystem::path& path, std::vector<std::string> sensor_names, SensorMask mask,
       double every)
      : file(path), names(std::move(sensor_names)), selected(mask), period(every) {
    file.stream()
        << "t,sensor,scale_x,scale_y,yaw_offset,filter_scale_x,filter_scale_y,filter_yaw_offset,"
           "filter_sd_scale_x,filter_sd_scale_y,filter_sd_yaw_offset\n";
  }
  void rows(double t) {
    for (std::size_t i = 0; i < names.size() && i < kMaxSensors; ++i) {
      if (!contains(selected, static_cast<int>(i))) continue;
      const SelfCalibrationEstimate &a = last[i], &f = last_filter[i];
      const Vec3& sd = last_sd[i];
      file.stream() << fmt::format("{},{},{},{},{},{},{},{},{},{},{}\n", t, names[i], a.scale_x,
                                   a.scale_y, a.yaw_offset, f.scale_x, f.scale_y, f.yaw_offset,
                                   sd.x(), sd.y(), sd.z());
    }
    written = t;
  }

  AtomicFile file;
  std::vector<std::string> names;
  SensorMask selected;
  double period;
  std::optional<double> first, written;
  double last_t = 0.0;
  std::array<SelfCalibrationEstimate, kMaxSensors> last{}, last_filter{};  ///< applied, filter's
  std::array<Vec3, kMaxSensors> last_sd = zeros<Vec3>();                   ///< the filter's sds
  bool any = false;
};

std::vector<SelfCalibrationRow> read_self_calibration_csv(const std::filesystem::path& file) {
  CsvReader in(file);
  const std::size_t t = in.required_column("t");
  const std::size_t sensor = in.required_column("sensor");
  const std::size_t sx = in.required_column("scale_x");
  const std::size_t sy = in.required_column("scale_y");
  const std::size_t yaw = in.required_column("yaw_offset");
  // The filter's columns, optional (files written before they existed).
  const auto fx = in.column("filter_scale_x"), fy = in.column("filter_scale_y"),
             fyaw = in.column("filter_yaw_offset");
  if ((fx || fy || fyaw) && !(fx && fy && fyaw)) {
    in.fail("filter_scale_x, filter_scale_y and filter_yaw_offset come together");
  }
  std::vector<SelfCalibrationRow> rows;
  while (in.next()) {
    SelfCalibrationRow r;
    r.t = in.time(t);
    r.sensor = std::string(in.field(sensor));
    if (r.sensor.empty()) in.fail_field(sensor, "empty sensor name");
    r.estimate.scale_x = in.number(sx);
    r.estimate.scale_y = in.number(sy);
    r.estimate.yaw_offset = in.number(yaw);
    if (!(r.estimate.scale_x > 0.0)) in.fail_field(sx, "must be > 0");
    if (!(r.estimate.scale_y > 0.0)) in.fail_field(sy, "must be > 0");
    r.filter = r.estimate;
    if (fx) {
      r.filter.scale_x = in.number(*fx);
      r.filter.scale_y = in.number(*fy);
      r.filter.yaw_offset = in.number(*fyaw);
      if (!(r.filter.scale_x > 0.0)) in.fail_field(*fx, "must be > 0");
      if (!(r.filter.scale_y > 0.0)) in.fail_field(*fy, "must be > 0");
    }
    rows.push_back(std::move(r));
  }
  return rows;
}

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
  m.last_filter = step.calibration_filter != nullptr ? *step.calibration_filter : m.last;
  if (step.calibration_sd != nullptr) m.last_sd = *step.calibration_sd;
  m.last_t = t;
  m.any = true;
  const double due = m.written ? std::floor((*m.written - *m.first) / m.period + 1e-9) + 1.0 : 0.0;
  if (!m.written || t - *m.first >= due * m.period - 1e-9) m.rows(t);
}

void SelfCalibrationCsvWriter::commit() {
  Impl& m = *impl_;
  if (m.any && (!m.written || *m.written != m.last_t)) m.rows(m.last_t);
  m.file.commit();
}

}  // namespace moa::io
