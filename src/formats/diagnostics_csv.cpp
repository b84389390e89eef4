#include "moa/formats/diagnostics_csv.hpp"

#include <fmt/format.h>

#include <cmath>
#include <ostream>

#include "moa/formats/atomic_file.hpp"
#include "moa/formats/csv.hpp"
#include "moa/formats/odometry_csv.hpp"

namespace moa::io {

struct DiagnosticsCsvWriter::Impl {
  Impl(const std::filesystem::path& path, std::vector<std::string> sensor_names, SensorMask mask)
      : file(path), names(std::move(sensor_names)), selected(mask) {
    file.stream() << "t,source,test_ratio,fused,reason,bias,scale\n";
  }
  /// `gyro`: the gyro's calibration after the epoch (imu rows), else empty.
  void row(double t, std::string_view source, real ratio, bool fused, std::string_view reason,
           const GyroModel* gyro = nullptr) {
    const std::string r = std::isnan(ratio) ? std::string() : fmt::format("{}", ratio);
    const std::string g =
        gyro != nullptr ? fmt::format("{},{}", gyro->bias(), gyro->scale()) : std::string(",");
    file.stream() << fmt::format("{},{},{},{},{},{}\n", t, source, r, fused ? 1 : 0, reason, g);
  }
  AtomicFile file;
  std::vector<std::string> names;
  SensorMask selected;
};

DiagnosticsCsvWriter::DiagnosticsCsvWriter(const std::filesystem::path& file,
                                           std::vector<std::string> names, SensorMask selected)
    : impl_(std::make_unique<Impl>(file, std::move(names), selected)) {}

DiagnosticsCsvWriter::~DiagnosticsCsvWriter() = default;

void DiagnosticsCsvWriter::write(const OdometryStep& step) {
  const RobustEstimate& e = step.estimate;
  const double t = step.t();
  for (std::size_t i = 0; i < impl_->names.size() && i < kMaxSensors; ++i) {
    if (!contains(impl_->selected, static_cast<int>(i))) continue;
    const bool used = contains(e.estimate.used, static_cast<int>(i));
    // The reason as odometry.csv's `excluded` writes it (with its noise flags).
    impl_->row(t, impl_->names[i], e.tests.sensor[i], used,
               used ? std::string{} : describe_exclusion(e.excluded[i], e.noise_flags[i]));
  }
  impl_->row(t, "wheels", e.tests.wheels, e.source == Source::kWheels, {});
  impl_->row(t, "prior", e.tests.prior, e.source == Source::kHold, {});
  // The gyro, in epochs that had one.
  if (!std::isnan(e.tests.gyro) || e.tests.gyro_fused || e.tests.gyro_saturated) {
    impl_->row(t, "imu", e.tests.gyro, e.tests.gyro_fused,
               e.tests.gyro_saturated ? "saturated" : (e.tests.gyro_fused ? "" : "inconsistent"),
               step.gyro);
  }
}

void DiagnosticsCsvWriter::commit() { impl_->file.commit(); }

std::vector<DiagnosticsRow> read_diagnostics_csv(const std::filesystem::path& file) {
  CsvReader in(file);
  const std::size_t t = in.required_column("t");
  const std::size_t source = in.required_column("source");
  const std::size_t ratio = in.required_column("test_ratio");
  const std::size_t fused = in.required_column("fused");
  const std::size_t reason = in.required_column("reason");
  // Added later (docs/formats/log.md): absent in older files.
  const std::optional<std::size_t> bias = in.column("bias"), scale = in.column("scale");
  std::vector<DiagnosticsRow> rows;
  while (in.next()) {
    DiagnosticsRow r;
    r.t = in.time(t);
    r.source = std::string(in.field(source));
    if (r.source.empty()) in.fail_field(source, "empty source");
    if (in.field(ratio).empty()) {
      r.test_ratio = std::nan("");
    } else {
      r.test_ratio = in.number(ratio);
      if (!(r.test_ratio >= 0.0)) in.fail_field(ratio, "must be >= 0");
    }
    const std::string_view f = in.field(fused);
    if (f != "0" && f != "1") in.fail_field(fused, "must be 0 or 1");
    r.fused = f == "1";
    r.reason = std::string(in.field(reason));
    // The gyro's calibration: both or neither, finite, the scale positive.
    const bool has_bias = bias && !in.field(*bias).empty();
    const bool has_scale = scale && !in.field(*scale).empty();
    if (has_bias != has_scale) {
      in.fail_field(has_bias ? *bias : *scale, "bias and scale come together");
    }
    if (has_bias) {
      r.bias = in.number(*bias);
      r.scale = in.number(*scale);
      if (!(*r.scale > 0.0)) in.fail_field(*scale, "must be > 0");
    }
    rows.push_back(std::move(r));
  }
  return rows;
}

}  // namespace moa::io
