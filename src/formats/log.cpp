#include "moa/formats/log.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <string_view>

#include "moa/core/plausible.hpp"
#include "moa/formats/atomic_file.hpp"
#include "moa/formats/csv.hpp"
#include "moa/formats/error.hpp"

namespace moa::io {
namespace {

// Counts are held as doubles downstream; beyond 2^53 they would silently
// lose their last digits.
constexpr std::int64_t kMaxExactCount = std::int64_t{1} << 53;

std::filesystem::path mice_file(const std::filesystem::path& path) {
  std::error_code ec;
  return std::filesystem::is_directory(path, ec) ? path / "mice.csv" : path;
}

// Per record type: which columns it needs and how one record becomes a row.
template <class Row>
class RowParser;

template <>
class RowParser<WheelRow> {
 public:
  explicit RowParser(const CsvReader& csv)
      : t_(csv.required_column("t")),
        vx_(csv.required_column("vx")),
        vy_(csv.required_column("vy")),
        omega_(csv.required_column("omega")) {}

  WheelRow parse(CsvReader& csv) const {
    WheelRow row;
    row.t = csv.time(t_);
    row.twist.v = {csv.plausible(vx_, kMaxPlausibleSpeed, "m/s", "a wheel twist"),
                   csv.plausible(vy_, kMaxPlausibleSpeed, "m/s", "a wheel twist")};
    row.twist.omega = csv.plausible(omega_, kMaxPlausibleRate, "rad/s", "a wheel twist");
    return row;
  }

 private:
  std::size_t t_, vx_, vy_, omega_;
};

template <>
class RowParser<ImuRow> {
 public:
  explicit RowParser(const CsvReader& csv)
      : t_(csv.required_column("t")),
        gz_(csv.required_column("gz")),
        faults_(csv.column("faults")) {}

  ImuRow parse(CsvReader& csv) const {
    ImuRow row{csv.time(t_), csv.plausible(gz_, kMaxPlausibleRate, "rad/s", "a gyro rate")};
    if (faults_) row.faults = static_cast<std::uint8_t>(csv.integer(*faults_, 0, 1));
    return row;
  }

 private:
  std::size_t t_, gz_;
  std::optional<std::size_t> faults_;
};

template <>
class RowParser<CameraRow> {
 public:
  explicit RowParser(const CsvReader& csv)
      : t_(csv.required_column("t")),
        x_(csv.required_column("x")),
        y_(csv.required_column("y")),
        theta_(csv.column("theta")),
        sx_(csv.column("sx")),
        sy_(csv.column("sy")) {
    // One standard deviation without the other cannot be used: say so
    // rather than drop it.
    if (sx_ && !sy_) csv.required_column("sy");
    if (sy_ && !sx_) csv.required_column("sx");
  }

  CameraRow parse(CsvReader& csv) const {
    CameraRow row;
    row.t = csv.time(t_);
    row.position = {csv.plausible(x_, kMaxPlausiblePosition, "m", "a camera fix"),
                    csv.plausible(y_, kMaxPlausiblePosition, "m", "a camera fix")};
    // In optional columns an empty field means "not given for this fix".
    if (theta_ && !csv.is_empty(*theta_)) {
      row.theta = csv.plausible(*theta_, kMaxPlausibleHeading, "rad", "a camera fix");
    }
    if (sx_) {
      if (csv.is_empty(*sx_) != csv.is_empty(*sy_)) {
        csv.fail("columns 'sx' and 'sy' must be both given or both empty");
      }
      if (!csv.is_empty(*sx_)) {
        const Eigen::Vector2d sigma(positive(csv, *sx_), positive(csv, *sy_));
        row.sigma = sigma;
      }
    }
    return row;
  }

 private:
  // A zero standard deviation would give the fix infinite weight.
  static double positive(const CsvReader& csv, std::size_t column) {
    const double value = csv.plausible(column, kMaxPlausiblePosition, "m", "a standard deviation");
    if (value <= 0.0) {
      csv.fail_field(column, fmt::format("must be > 0 (found {})", value));
    }
    return value;
  }

  std::size_t t_, x_, y_;
  std::optional<std::size_t> theta_, sx_, sy_;
};

template <>
class RowParser<TruthRow> {
 public:
  explicit RowParser(const CsvReader& csv)
      : t_(csv.required_column("t")),
        x_(csv.required_column("x")),
        y_(csv.required_column("y")),
        theta_(csv.required_column("theta")) {}

  TruthRow parse(CsvReader& csv) const {
    TruthRow row;
    row.t = csv.time(t_);
    row.pose.t = {csv.plausible(x_, kMaxPlausiblePosition, "m", "a pose"),
                  csv.plausible(y_, kMaxPlausiblePosition, "m", "a pose")};
    row.pose.theta = csv.plausible(theta_, kMaxPlausibleHeading, "rad", "a pose");
    return row;
  }

 private:
  std::size_t t_, x_, y_, theta_;
};

}  // namespace

// ---------------------------------------------------------------- MiceReader

struct MiceReader::Impl {
  Impl(const std::filesystem::path& path, const RobotConfig& config)
      : csv(mice_file(path)),
        names(config.names),
        t(csv.required_column("t")),
        sensor(csv.required_column("sensor")),
        dx(csv.required_column("dx")),
        dy(csv.required_column("dy")),
        squal(csv.column("squal")),
        flags(csv.column("flags")),
        rows(names.size(), 0),
        last(names.size()) {
    roles.assign(csv.columns(), Role::kOther);
    roles[t] = Role::kTime;
    roles[sensor] = Role::kSensor;
    roles[dx] = Role::kDx;
    roles[dy] = Role::kDy;
    if (squal) roles[*squal] = Role::kSqual;
    if (flags) roles[*flags] = Role::kFlags;
    plain_layout = t == 0 && sensor == 1 && dx == 2 && dy == 3 && roles.size() <= 6 &&
                   std::all_of(roles.begin() + 4, roles.end(),
                               [](Role r) { return r == Role::kSqual || r == Role::kFlags; });
  }

  std::optional<SensorRow> read() {
    if (!csv.next_record()) return std::nullopt;
    SensorRow row;
    std::string_view name;
    const bool plain = read_plain(row, name);
    if (!plain) read_counts(row, name);
    // A second row of a sensor at the same time, both with counts, is a
    // duplicated line (its counts would be counted twice), never a real
    // report; a zero row at the same time adds nothing and is accepted.
    const auto i = static_cast<std::size_t>(row.sensor);
    const bool moved = row.counts.x() != 0.0 || row.counts.y() != 0.0;
    if (moved && rows[i] > 0 && last[i].t == row.t && last[i].moved) {
      csv.fail(fmt::format("duplicate row: sensor '{}' already has a row at t = {} (line {})", name,
                           row.t, last[i].line));
    }
    ++rows[i];
    if (!(rows[i] > 1 && last[i].t == row.t && !moved)) last[i] = {row.t, csv.line(), moved};
    if (!plain) read_quality(row);
    return row;
  }

  // The record in one pass, when the columns are t,sensor,dx,dy[,squal][,flags]
  // (as moa writes mice.csv) and every field is in its plainest form: a time
  // "[-]ddd[.ddd]" not earlier than the previous one, a known name, integers
  // of digits in range, no spaces, as many fields as columns. The values are
  // then those read_counts() and read_quality() read (the same number
  // parsers), and they would report nothing. False, with nothing changed,
  // for anything else: they read the record and report its errors.
  bool read_plain(SensorRow& row, std::string_view& name) {
    if (!plain_layout) return false;
    const std::string_view record = csv.record();
    const char* p = record.data();
    const char* const end = p + record.size();
    const auto comma = [&] {
      if (p == end || *p != ',') return false;
      ++p;
      return true;
    };
    ShortDecimal t_text;
    p = scan_decimal(p, end, t_text);
    if (!p || !comma()) return false;
    // The sensors of one report share its time: the same text, the same
    // value, without the division.
    if (!(t_text == last_t_text)) {
      last_t_text = t_text;
      last_t_value = t_text.value();
    }
    const double t_read = last_t_value;
    const char* const first = p;
    while (p != end && *p != ',') ++p;
    name = {first, static_cast<std::size_t>(p - first)};
    const int index = find_sensor(name);
    if (index < 0) return false;
    std::int64_t counts[2] = {0, 0};
    for (auto& v : counts) {
      if (!comma()) return false;
      p = scan_integer(p, end, v);
      if (!p || v < -kMaxExactCount || v > kMaxExactCount) return false;
    }
    std::optional<std::uint8_t> quality[2];  // squal, flags
    for (std::size_t k = 4; k < roles.size(); ++k) {
      if (!comma()) return false;
      if (p == end || *p == ',') continue;  // empty: not reported in this row
      std::int64_t v = 0;
      p = scan_integer(p, end, v);
      if (!p || v < 0 || v > 255) return false;
      quality[roles[k] == Role::kSqual ? 0 : 1] = static_cast<std::uint8_t>(v);
    }
    if (p != end || !csv.accept_time(t_read)) return false;
    row.t = t_read;
    row.sensor = index;
    row.counts = {static_cast<double>(counts[0]), static_cast<double>(counts[1])};
    row.squal = quality[0];
    row.flags = quality[1].value_or(0);
    return true;
  }

  void read_counts(SensorRow& row, std::string_view& name) {
    csv.split_record();
    row.t = csv.time(t);
    name = csv.field(sensor);
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end()) {
      // A log of another robot, or the wrong config: say which names it has.
      csv.fail(fmt::format("unknown sensor '{}' (the config's sensors: {})", excerpt(name),
                           fmt::join(names, ", ")));
    }
    row.sensor = static_cast<int>(it - names.begin());
    row.counts = {static_cast<double>(csv.integer(dx, -kMaxExactCount, kMaxExactCount)),
                  static_cast<double>(csv.integer(dy, -kMaxExactCount, kMaxExactCount))};
  }

  void read_quality(SensorRow& row) const {
    // In optional columns an empty field means "not reported in this row".
    if (squal && !csv.is_empty(*squal)) {
      row.squal = static_cast<std::uint8_t>(csv.integer(*squal, 0, 255));
    }
    if (flags && !csv.is_empty(*flags)) {
      row.flags = static_cast<std::uint8_t>(csv.integer(*flags, 0, 255));
    }
  }

  /// Index of the sensor called `name`, -1 if none; the one after the
  /// previous row's is tried first (rows usually take the sensors in turn).
  int find_sensor(std::string_view name) {
    const std::size_t n = names.size();
    if (n == 0 || name.empty() || name.front() == ' ' || name.front() == '\t' ||
        name.back() == ' ' || name.back() == '\t') {
      return -1;
    }
    std::size_t i = next_sensor;
    for (std::size_t k = 0; k < n; ++k, i = i + 1 == n ? 0 : i + 1) {
      if (names[i].size() == name.size() && same_bytes(names[i].data(), name.data(), name.size())) {
        next_sensor = i + 1 == n ? 0 : i + 1;
        return static_cast<int>(i);
      }
    }
    return -1;
  }

  // Names are short: a byte loop beats a memcmp call.
  static bool same_bytes(const char* a, const char* b, std::size_t n) {
    for (std::size_t k = 0; k < n; ++k) {
      if (a[k] != b[k]) return false;
    }
    return true;
  }

  enum class Role : std::uint8_t { kOther, kTime, kSensor, kDx, kDy, kSqual, kFlags };

  CsvReader csv;
  std::vector<std::string> names;  // a copy: the reader may outlive the config
  std::size_t t, sensor, dx, dy;
  std::optional<std::size_t> squal, flags;
  std::vector<Role> roles;      // per column
  bool plain_layout = false;    // t,sensor,dx,dy[,squal][,flags]: read_plain() applies
  std::size_t next_sensor = 0;  // tried first by find_sensor()
  ShortDecimal last_t_text;     // read_plain()'s last time and its value
  double last_t_value = 0.0;
  std::optional<SensorRow> peeked;
  std::optional<double> start;
  std::vector<std::size_t> rows;  // per sensor, read so far
  struct Last {
    double t = 0.0;
    std::size_t line = 0;
    bool moved = false;
  };
  std::vector<Last> last;  // per sensor: its last row with counts, or its last row
};

MiceReader::MiceReader(const std::filesystem::path& path, const RobotConfig& config)
    : impl_(std::make_unique<Impl>(path, config)) {}

MiceReader::~MiceReader() = default;

double MiceReader::start_time() {
  if (!impl_->start) {
    impl_->peeked = impl_->read();
    if (!impl_->peeked) throw Error(fmt::format("{}: no data rows", impl_->csv.file()));
    impl_->start = impl_->peeked->t;
  }
  return *impl_->start;
}

const std::string& MiceReader::file() const { return impl_->csv.file(); }
std::size_t MiceReader::line() const { return impl_->csv.line(); }
const std::vector<std::size_t>& MiceReader::rows_per_sensor() const { return impl_->rows; }

std::optional<SensorRow> MiceReader::next() {
  if (impl_->peeked) {
    auto row = std::move(impl_->peeked);
    impl_->peeked.reset();
    return row;
  }
  auto row = impl_->read();
  if (row && !impl_->start) impl_->start = row->t;
  return row;
}

// ----------------------------------------------------------------- RowReader

template <class Row>
struct RowReader<Row>::Impl {
  explicit Impl(const std::filesystem::path& file) : csv(file), parser(csv) {}
  CsvReader csv;
  RowParser<Row> parser;
};

template <class Row>
RowReader<Row>::RowReader(const std::filesystem::path& file)
    : impl_(std::make_unique<Impl>(file)) {}

template <class Row>
RowReader<Row>::~RowReader() = default;

template <class Row>
std::optional<Row> RowReader<Row>::next() {
  if (!impl_->csv.next()) return std::nullopt;
  return impl_->parser.parse(impl_->csv);
}

template class RowReader<WheelRow>;
template class RowReader<CameraRow>;
template class RowReader<ImuRow>;
template class RowReader<TruthRow>;

// ------------------------------------------------------------ OdometryWriter

namespace {

constexpr std::array<std::string_view, 7> kOdometryColumns{"t",  "x",  "y",    "theta",
                                                           "vx", "vy", "omega"};

// Text that would split a field or end the record early.
bool breaks_csv(std::string_view text) {
  for (const char c : text) {
    if (c == ',' || c == '\n' || c == '\r') return true;
  }
  return false;
}

}  // namespace

struct OdometryWriter::Impl {
  Impl(const std::filesystem::path& path, std::vector<std::string> extra)
      : file_name(path.string()), extra_columns(std::move(extra)), file(std::in_place, path) {}
  Impl(std::FILE* out, std::vector<std::string> extra)
      : file_name("<stdout>"), extra_columns(std::move(extra)), stream(out) {}

  // Rows are composed in `pending`; a file gets it in blocks (one stream
  // write per row would cost more than formatting the row), a stream row by
  // row.
  char* reserve(std::size_t size) {
    if (pending.size() - used < size) {
      if (file && used > 0) drain();
      if (pending.size() - used < size) pending.resize(used + std::max(size, kPendingBlock));
    }
    return pending.data() + used;
  }

  void wrote(const char* end) {
    used = static_cast<std::size_t>(end - pending.data());
    if (!file) {
      if (std::fwrite(pending.data(), 1, used, stream) != used) fail("write failed");
      used = 0;
    } else if (used >= kPendingBlock) {
      drain();
    }
  }

  void put(std::string_view text) {
    char* out = reserve(text.size());
    wrote(std::copy(text.begin(), text.end(), out));
  }

  void drain() {
    file->stream().write(pending.data(), static_cast<std::streamsize>(used));
    // The disk writes what is written while the rows go on, rather than
    // all of it in commit()'s fsync.
    drained += used;
    if (drained >= kWritebackBlock) {
      file->start_writeback();
      drained = 0;
    }
    used = 0;
  }

  [[noreturn]] void fail(std::string_view what) const {
    throw Error(printable(fmt::format("{}: {}", file_name, what)));
  }

  static constexpr std::size_t kPendingBlock = std::size_t{1} << 16;
  static constexpr std::size_t kWritebackBlock = std::size_t{1} << 23;

  std::string file_name;
  std::vector<std::string> extra_columns;
  std::optional<AtomicFile> file;  ///< or, when writing a stream:
  std::FILE* stream = nullptr;
  std::vector<char> pending;  ///< [0, used): rows not yet handed to the file
  std::size_t used = 0;
  std::size_t drained = 0;  ///< bytes handed to the file since the last start_writeback()
  std::string joined;       ///< write()'s extra values, joined
  std::optional<double> last_t;
  bool committed = false;
};

OdometryWriter::OdometryWriter(const std::filesystem::path& file,
                               std::vector<std::string> extra_columns)
    : impl_(std::make_unique<Impl>(file, std::move(extra_columns))) {
  header();
}

OdometryWriter::OdometryWriter(std::FILE* stream, std::vector<std::string> extra_columns)
    : impl_(std::make_unique<Impl>(stream, std::move(extra_columns))) {
  header();
}

void OdometryWriter::header() {
  std::vector<std::string_view> columns(kOdometryColumns.begin(), kOdometryColumns.end());
  for (const auto& name : impl_->extra_columns) {
    // Readers trim spaces around fields, so such a name would not read back.
    const bool padded = name.empty() || name.front() == ' ' || name.front() == '\t' ||
                        name.back() == ' ' || name.back() == '\t';
    if (padded || breaks_csv(name) || name.front() == '#') {
      impl_->fail(fmt::format("invalid column name '{}'", name));
    }
    if (std::find(columns.begin(), columns.end(), name) != columns.end()) {
      impl_->fail(fmt::format("duplicate column '{}'", name));
    }
    columns.push_back(name);
  }
  impl_->put(fmt::format("{}\n", fmt::join(columns, ",")));
}

OdometryWriter::~OdometryWriter() = default;

namespace {

std::array<double, 7> row_values(double t, const Pose2& pose, const Twist2& twist) {
  return {t, pose.t.x(), pose.t.y(), pose.theta, twist.v.x(), twist.v.y(), twist.omega};
}

}  // namespace

void OdometryWriter::check(const std::array<double, 7>& values) {
  Impl& impl = *impl_;
  const double t = values[0];
  if (impl.committed) impl.fail("write after commit");
  for (std::size_t i = 0; i < values.size(); ++i) {
    // The log format admits no NaN or infinity; writing one would make a
    // file that no reader of the format accepts.
    if (!std::isfinite(values[i])) {
      impl.fail(
          fmt::format("row at t={}: {} is not finite ({})", t, kOdometryColumns[i], values[i]));
    }
  }
  if (impl.last_t && t < *impl.last_t) {
    impl.fail(fmt::format("time goes backwards ({} after {})", t, *impl.last_t));
  }
}

char* OdometryWriter::put_numbers(const std::array<double, 7>& values, std::size_t max_extra) {
  Impl& impl = *impl_;
  impl.last_t = values[0];
  // The shortest text that reads back as the same double: exact, and no
  // longer than needed.
  char* out = impl.reserve(values.size() * (kMaxNumberText + 1) + max_extra + 1);
  out = write_shortest_time(out, values[0]);
  for (std::size_t i = 1; i < values.size(); ++i) {
    *out++ = ',';
    out = write_shortest(out, values[i]);
  }
  return out;
}

void OdometryWriter::put_row(const std::array<double, 7>& values, std::string_view extra) {
  char* out = put_numbers(values, extra.size());
  out = std::copy(extra.begin(), extra.end(), out);
  end_row(out);
}

char* OdometryWriter::begin_row(double t, const Pose2& pose, const Twist2& twist,
                                std::size_t max_extra) {
  const auto values = row_values(t, pose, twist);
  check(values);
  return put_numbers(values, max_extra);
}

void OdometryWriter::end_row(char* end) {
  *end++ = '\n';
  impl_->wrote(end);
}

void OdometryWriter::write(double t, const Pose2& pose, const Twist2& twist,
                           const std::vector<std::string>& extra) {
  Impl& impl = *impl_;
  if (impl.committed) impl.fail("write after commit");
  if (extra.size() != impl.extra_columns.size()) {
    impl.fail(fmt::format("row at t={}: expected {} extra values, found {}", t,
                          impl.extra_columns.size(), extra.size()));
  }
  const auto values = row_values(t, pose, twist);
  check(values);
  for (std::size_t i = 0; i < extra.size(); ++i) {
    if (breaks_csv(extra[i])) {
      impl.fail(fmt::format("row at t={}: value of column '{}' contains a comma or a line break", t,
                            impl.extra_columns[i]));
    }
  }
  impl.joined.clear();
  for (const auto& value : extra) {
    impl.joined += ',';
    impl.joined += value;
  }
  put_row(values, impl.joined);
}

void OdometryWriter::write_joined(double t, const Pose2& pose, const Twist2& twist,
                                  std::string_view extra) {
  assert(static_cast<std::size_t>(std::count(extra.begin(), extra.end(), ',')) ==
         impl_->extra_columns.size());
  assert(extra.find_first_of("\r\n") == std::string_view::npos);
  const auto values = row_values(t, pose, twist);
  check(values);
  put_row(values, extra);
}

void OdometryWriter::flush() {
  if (impl_->stream) std::fflush(impl_->stream);
}

void OdometryWriter::commit() {
  if (impl_->committed) impl_->fail("already committed");
  if (impl_->file) {
    impl_->drain();
    impl_->file->commit();
  } else {
    std::fflush(impl_->stream);
  }
  impl_->committed = true;
}

}  // namespace moa::io
