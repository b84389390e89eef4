#include "moa/formats/odometry_csv.hpp"
#include "moa/core/plausible.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <string_view>

#include "moa/formats/csv.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/log.hpp"

namespace moa::io {
namespace {

constexpr std::array<std::pair<std::uint8_t, std::string_view>, 3> kNoiseFlagNames{{
    {kNoiseOverSpeed, "over-speed"},
    {kNoiseLowSqual, "low-squal"},
    {kNoiseOverflow, "overflow"},
}};

void append_exclusion(std::string& out, Exclusion reason, std::uint8_t noise_flags) {
  out += to_name(reason);
  for (const auto& [bit, name] : kNoiseFlagNames) {
    if (noise_flags & bit) {
      out += '/';
      out += name;
    }
  }
}

std::vector<std::string> extra_columns(bool fused, bool scaled) {
  std::vector<std::string> columns{"sd_vx", "sd_vy", "sd_omega", "source", "used", "excluded"};
  if (fused) columns.insert(columns.end(), {"pxx", "pxy", "pyy", "ptt"});
  if (scaled) {
    columns.insert(columns.end(), {"scale_v", "scale_omega", "sd_scale_v", "sd_scale_omega"});
  }
  return columns;
}

// scale_v, scale_omega, sd_scale_v, sd_scale_omega of a step.
std::array<double, 4> scale_fields(const OdometryStep& step) {
  return {step.scale(0), step.scale(1), std::sqrt(std::max(step.scale_covariance(0, 0), 0.0)),
          std::sqrt(std::max(step.scale_covariance(1, 1), 0.0))};
}

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& name : names) out += (out.empty() ? "" : ", ") + name;
  return out;
}

}  // namespace

std::string describe_exclusion(Exclusion reason, std::uint8_t noise_flags) {
  std::string out;
  append_exclusion(out, reason, noise_flags);
  return out;
}

// ------------------------------------------------------------------ writer

struct OdometryCsvWriter::Impl {
  template <class Target>
  Impl(const Target& target, std::vector<std::string> sensor_names, bool with_cov, bool with_scale)
      : names(std::move(sensor_names)),
        fused(with_cov),
        scaled(with_scale),
        writer(target, extra_columns(with_cov, with_scale)) {
    for (const auto& name : names) {
      if (name.find_first_of(",\r\n") != std::string::npos) names_break_csv = true;
    }
  }

  // The selection of an estimate: what the source, used and excluded fields
  // are written from.
  struct Selection {
    Source source = Source::kMice;
    SensorMask used = 0;
    std::array<Exclusion, kMaxSensors> excluded{};
    std::array<std::uint8_t, kMaxSensors> noise_flags{};
    bool operator==(const Selection&) const = default;
  };

  // ",source,used,excluded" of `e`. It rarely changes from one epoch to the
  // next, so it is composed only when it does.
  // Whether `e` has the selection of `text`: its source, used sensors, and
  // the exclusions of the sensors it did not use (Selection as composed
  // below, compared in place).
  bool same_selection(const RobustEstimate& e) const {
    if (!selection || selection->source != e.source || selection->used != e.estimate.used) {
      return false;
    }
    const std::size_t n = std::min(names.size(), static_cast<std::size_t>(kMaxSensors));
    for (std::size_t i = 0; i < n; ++i) {
      if (contains(e.estimate.used, static_cast<int>(i))) continue;
      if (selection->excluded[i] != e.excluded[i] ||
          selection->noise_flags[i] != e.noise_flags[i]) {
        return false;
      }
    }
    return true;
  }

  std::string_view selection_text(const RobustEstimate& e) {
    if (same_selection(e)) return text;
    Selection now{e.source, e.estimate.used, e.excluded, e.noise_flags};
    for (std::size_t i = 0; i < kMaxSensors; ++i) {
      if (i >= names.size() || contains(now.used, static_cast<int>(i))) {
        now.excluded[i] = Exclusion::kNone;
        now.noise_flags[i] = 0;
      }
    }
    selection = now;
    // fmt, not operator+= of a const char*: GCC 12 at -O3 misreads the
    // latter's length (-Wstringop-overflow, a false positive).
    text = fmt::format(",{},", to_name(e.source));
    bool first = true;
    for (std::size_t i = 0; i < names.size(); ++i) {
      if (!contains(now.used, static_cast<int>(i))) continue;
      if (!first) text += '+';
      text += names[i];
      first = false;
    }
    text += ',';
    first = true;
    for (std::size_t i = 0; i < names.size(); ++i) {
      if (contains(now.used, static_cast<int>(i))) continue;
      if (!first) text += ';';
      text += names[i];
      text += ':';
      append_exclusion(text, now.excluded[i], now.noise_flags[i]);
      first = false;
    }
    return text;
  }

  std::vector<std::string> names;
  bool fused;
  bool scaled;
  OdometryWriter writer;
  /// A name with a comma or a line break: the rows go through the writer's
  /// checks, which name the column it would break.
  bool names_break_csv = false;
  std::optional<Selection> selection;  ///< of `text`
  std::string text;
};

OdometryCsvWriter::OdometryCsvWriter(const std::filesystem::path& file,
                                     std::vector<std::string> names, bool fused, bool scaled)
    : impl_(std::make_unique<Impl>(file, std::move(names), fused, scaled)) {}

OdometryCsvWriter::OdometryCsvWriter(std::FILE* stream, std::vector<std::string> names, bool fused,
                                     bool scaled)
    : impl_(std::make_unique<Impl>(stream, std::move(names), fused, scaled)) {}

OdometryCsvWriter::~OdometryCsvWriter() = default;

void OdometryCsvWriter::flush() { impl_->writer.flush(); }

void OdometryCsvWriter::write(const OdometryStep& step) { write(step.t(), step); }

void OdometryCsvWriter::write(double t, const OdometryStep& step) {
  Impl& s = *impl_;
  const RobustEstimate& e = step.estimate;
  if (s.names_break_csv) {
    // The fields one by one, as the writer's generic checks want them.
    const auto number = [](double v) {
      char buffer[kMaxNumberText];
      return std::string(buffer, write_shortest(buffer, v));
    };
    std::vector<std::string> fields;
    for (int i = 0; i < 3; ++i) {
      fields.push_back(number(std::sqrt(std::max(e.estimate.covariance(i, i), 0.0))));
    }
    fields.emplace_back(to_name(e.source));
    fields.emplace_back();
    fields.emplace_back();
    for (std::size_t i = 0; i < s.names.size(); ++i) {
      if (contains(e.estimate.used, static_cast<int>(i))) {
        if (!fields[4].empty()) fields[4] += '+';
        fields[4] += s.names[i];
      } else {
        if (!fields[5].empty()) fields[5] += ';';
        fields[5] += s.names[i] + ':';
        append_exclusion(fields[5], e.excluded[i], e.noise_flags[i]);
      }
    }
    if (s.fused) {
      const Eigen::Matrix3d& p = step.pose_covariance;
      for (const double v : {p(0, 0), p(0, 1), p(1, 1), p(2, 2)}) fields.push_back(number(v));
    }
    if (s.scaled) {
      for (const double v : scale_fields(step)) fields.push_back(number(v));
    }
    s.writer.write(t, step.pose, e.estimate.twist, fields);
    return;
  }
  // sd_vx, sd_vy, sd_omega, then the selection, then pxx, pxy, pyy, ptt,
  // then scale_v, scale_omega and their sd, written in place after the
  // row's numbers.
  const std::string_view selection = s.selection_text(e);
  constexpr std::size_t kNumbers = 11 * (kMaxNumberText + 1);
  char* out = s.writer.begin_row(t, step.pose, e.estimate.twist, kNumbers + selection.size());
  for (int i = 0; i < 3; ++i) {
    *out++ = ',';
    out = write_shortest(out, std::sqrt(std::max(e.estimate.covariance(i, i), 0.0)));
  }
  out = std::copy(selection.begin(), selection.end(), out);
  if (s.fused) {
    const Eigen::Matrix3d& p = step.pose_covariance;
    for (const double v : {p(0, 0), p(0, 1), p(1, 1), p(2, 2)}) {
      *out++ = ',';
      out = write_shortest(out, v);
    }
  }
  if (s.scaled) {
    for (const double v : scale_fields(step)) {
      *out++ = ',';
      out = write_shortest(out, v);
    }
  }
  s.writer.end_row(out);
}

void OdometryCsvWriter::commit() { impl_->writer.commit(); }

// ------------------------------------------------------------------ reader

struct OdometryCsvReader::Impl {
  Impl(const std::filesystem::path& file, const RobotConfig& cfg, std::string cfg_path)
      : csv(file), config(cfg), config_path(std::move(cfg_path)) {
    for (const char* name : {"t", "x", "y", "theta", "vx", "vy", "omega"}) {
      columns.push_back(csv.required_column(name));
    }
    used = csv.column("used");
    excluded = csv.column("excluded");
    source = csv.column("source");
    const auto a = csv.column("sd_vx"), b = csv.column("sd_vy"), c = csv.column("sd_omega");
    if (a && b && c) sd = {*a, *b, *c};
    const auto pxx = csv.column("pxx"), pxy = csv.column("pxy"), pyy = csv.column("pyy"),
               ptt = csv.column("ptt");
    if (pxx && pxy && pyy && ptt) cov = {*pxx, *pxy, *pyy, *ptt};
    const auto sv = csv.column("scale_v"), sw = csv.column("scale_omega");
    if (sv && sw) scale = {*sv, *sw};
    const auto dv = csv.column("sd_scale_v"), dw = csv.column("sd_scale_omega");
    if (dv && dw) scale_sd = {*dv, *dw};
  }

  int sensor(std::size_t column, std::string_view name, const OdometryRow& r) const {
    const auto index = config.index_of(name);
    if (!index) {
      csv.fail_field(column, fmt::format("unknown sensor '{}' ({} has {})", printable(name),
                                         config_path, joined(config.names)));
    }
    if (contains(r.listed, *index)) {
      csv.fail_field(column, fmt::format("sensor '{}' is listed twice", name));
    }
    return *index;
  }

  void parse_used(std::size_t column, OdometryRow& r) const {
    const std::string_view text = csv.field(column);
    if (text.empty()) return;
    std::size_t start = 0;
    while (true) {
      const std::size_t end = std::min(text.find('+', start), text.size());
      const int i = sensor(column, text.substr(start, end - start), r);
      r.used |= SensorMask{1} << i;
      r.listed |= SensorMask{1} << i;
      if (end == text.size()) return;
      start = end + 1;
    }
  }

  void parse_excluded(std::size_t column, OdometryRow& r) const {
    const std::string_view text = csv.field(column);
    if (text.empty()) return;
    std::size_t start = 0;
    while (true) {
      const std::size_t end = std::min(text.find(';', start), text.size());
      const std::string_view entry = text.substr(start, end - start);
      const std::size_t colon = entry.rfind(':');
      if (colon == std::string_view::npos || colon == 0 || colon + 1 == entry.size()) {
        csv.fail_field(column, fmt::format("'{}' is not name:reason", printable(entry)));
      }
      const int i = sensor(column, entry.substr(0, colon), r);
      r.listed |= SensorMask{1} << i;
      std::string_view rest = entry.substr(colon + 1);
      const std::size_t slash = std::min(rest.find('/'), rest.size());
      const std::string_view reason = rest.substr(0, slash);
      const auto u = static_cast<std::size_t>(i);
      // A reason, not "used" (a used sensor is in the `used` column).
      const auto x = from_name<Exclusion>(reason);
      if (x && *x != Exclusion::kNone) r.excluded[u] = *x;
      if (!x || *x == Exclusion::kNone) {
        csv.fail_field(
            column, fmt::format("'{}': unknown reason '{}'", printable(entry), printable(reason)));
      }
      rest = slash < rest.size() ? rest.substr(slash + 1) : std::string_view{};
      while (!rest.empty()) {
        const std::size_t next = std::min(rest.find('/'), rest.size());
        const std::string_view flag = rest.substr(0, next);
        bool found = false;
        for (const auto& [bit, name] : kNoiseFlagNames) {
          if (flag == name) {
            r.noise_flags[u] |= bit;
            found = true;
          }
        }
        if (!found) {
          csv.fail_field(column,
                         fmt::format("'{}': unknown flag '{}'", printable(entry), printable(flag)));
        }
        rest = next < rest.size() ? rest.substr(next + 1) : std::string_view{};
      }
      if (end == text.size()) return;
      start = end + 1;
    }
  }

  CsvReader csv;
  const RobotConfig& config;
  std::string config_path;
  std::vector<std::size_t> columns;
  std::optional<std::size_t> used, excluded, source;
  std::optional<std::array<std::size_t, 3>> sd;
  std::optional<std::array<std::size_t, 4>> cov;
  std::optional<std::array<std::size_t, 2>> scale, scale_sd;
};

OdometryCsvReader::OdometryCsvReader(const std::filesystem::path& file, const RobotConfig& config,
                                     std::string config_path)
    : impl_(std::make_unique<Impl>(file, config, std::move(config_path))) {}

OdometryCsvReader::~OdometryCsvReader() = default;

bool OdometryCsvReader::has_selection() const { return impl_->used && impl_->excluded; }
const std::string& OdometryCsvReader::file() const { return impl_->csv.file(); }

std::optional<OdometryRow> OdometryCsvReader::next() {
  Impl& s = *impl_;
  if (!s.csv.next()) return std::nullopt;
  const auto& c = s.columns;
  OdometryRow r;
  r.t = s.csv.time(c[0]);
  const auto& f = s.csv;
  r.pose = Pose2{{f.plausible(c[1], kMaxPlausiblePosition, "m", "a pose"),
                  f.plausible(c[2], kMaxPlausiblePosition, "m", "a pose")},
                 f.plausible(c[3], kMaxPlausibleHeading, "rad", "a pose")};
  r.twist = Twist2{{f.plausible(c[4], kMaxPlausibleSpeed, "m/s", "a twist"),
                    f.plausible(c[5], kMaxPlausibleSpeed, "m/s", "a twist")},
                   f.plausible(c[6], kMaxPlausibleRate, "rad/s", "a twist")};
  if (s.sd)
    r.sd = Eigen::Vector3d(s.csv.number((*s.sd)[0]), s.csv.number((*s.sd)[1]),
                           s.csv.number((*s.sd)[2]));
  if (s.cov) {
    r.pose_covariance = Eigen::Vector4d(s.csv.number((*s.cov)[0]), s.csv.number((*s.cov)[1]),
                                        s.csv.number((*s.cov)[2]), s.csv.number((*s.cov)[3]));
  }
  if (s.scale) r.scale = Eigen::Vector2d(s.csv.number((*s.scale)[0]), s.csv.number((*s.scale)[1]));
  if (s.scale_sd) {
    r.scale_sd = Eigen::Vector2d(s.csv.number((*s.scale_sd)[0]), s.csv.number((*s.scale_sd)[1]));
  }
  if (s.source) {
    const std::string_view text = s.csv.field(*s.source);
    r.source = from_name<Source>(text);
    if (!r.source) {
      s.csv.fail_field(*s.source,
                       fmt::format("unknown source '{}' (mice, wheels, hold)", printable(text)));
    }
  }
  if (s.used) s.parse_used(*s.used, r);
  if (s.excluded) s.parse_excluded(*s.excluded, r);
  return r;
}

}  // namespace moa::io
