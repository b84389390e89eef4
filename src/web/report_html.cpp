// render_report: the page. Tables are static HTML (readable without
// script); the plots' data goes into one JSON element that the page's
// script (report_page.js) hands to Chart.js. Everything is inlined.
#include <fmt/format.h>

#include <cmath>
#include <numbers>
#include <optional>
#include <string_view>
#include <tuple>

#include "moa/web/html.hpp"
#include "moa/web/report.hpp"
#include "report_assets.hpp"

namespace moa::io {
namespace {

/// Builds JSON text. Strings are escaped so that they cannot end the
/// <script> element they sit in ('<', '>' and '&' as \u escapes).
class Json {
 public:
  /// A member's name; its value follows without a comma.
  Json& key(std::string_view name) {
    comma();
    quoted(name);
    out_ += ':';
    first_ = true;
    return *this;
  }
  Json& string(std::string_view text) {
    comma();
    quoted(text);
    return *this;
  }
  /// `digits` significant digits; NaN and infinity as null.
  Json& number(double x, int digits = 7) {
    comma();
    if (std::isfinite(x)) {
      out_ += fmt::format("{:.{}g}", x, digits);
    } else {
      out_ += "null";
    }
    return *this;
  }
  Json& boolean(bool b) {
    comma();
    out_ += b ? "true" : "false";
    return *this;
  }
  Json& null() {
    comma();
    out_ += "null";
    return *this;
  }
  Json& open(char bracket) {
    comma();
    out_ += bracket;
    first_ = true;
    return *this;
  }
  Json& close(char bracket) {
    out_ += bracket;
    first_ = false;
    return *this;
  }
  template <class Range, class Get>
  Json& numbers(const Range& range, Get get, int digits = 7) {
    open('[');
    for (const auto& item : range) number(get(item), digits);
    return close(']');
  }
  const std::string& text() const { return out_; }

 private:
  void quoted(std::string_view text) {
    out_ += '"';
    for (const char c : text) {
      const auto u = static_cast<unsigned char>(c);
      if (c == '"' || c == '\\') {
        out_ += '\\';
        out_ += c;
      } else if (u < 0x20 || c == '<' || c == '>' || c == '&') {
        out_ += fmt::format("\\u{:04x}", u);
      } else {
        out_ += c;
      }
    }
    out_ += '"';
  }
  void comma() {
    if (!first_) out_ += ',';
    first_ = false;
  }
  std::string out_;
  bool first_ = true;
};

constexpr int kTimeDigits = 10;  // 0.1 ms over a day-long log

void mounts_json(Json& j, const RobotConfig& config) {
  j.open('[');
  for (int i = 0; i < config.array.size(); ++i) {
    const SensorMount& s = config.array[i];
    j.open('{');
    j.key("name").string(config.names[static_cast<std::size_t>(i)]);
    j.key("x").number(s.position.x());
    j.key("y").number(s.position.y());
    j.key("yaw").number(s.yaw);
    j.key("mirrored").boolean(s.mirrored);
    j.key("max_speed");
    if (s.max_speed) {
      j.number(*s.max_speed);
    } else {
      j.null();
    }
    j.close('}');
  }
  j.close(']');
}

/// odometry.csv has a `source` column (the timeline's last row).
bool has_source(const ReportModel& m) {
  for (const std::size_t epochs : m.sources) {
    if (epochs > 0) return true;
  }
  return false;
}

std::string data_json(const ReportModel& m) {
  Json j;
  j.open('{');
  j.key("title").string(m.title);
  j.key("sensors");
  mounts_json(j, m.config);
  j.key("calibrated");
  if (m.calibrated) {
    mounts_json(j, *m.calibrated);
  } else {
    j.null();
  }
  j.key("t0").number(m.t_first, kTimeDigits);
  j.key("t1").number(m.t_last, kTimeDigits);
  const auto& bins = m.bins;
  j.key("bins").open('{');
  j.key("t").numbers(
      bins, [](const ReportBin& b) { return b.t; }, kTimeDigits);
  j.key("x").numbers(bins, [](const ReportBin& b) { return b.pose.t.x(); });
  j.key("y").numbers(bins, [](const ReportBin& b) { return b.pose.t.y(); });
  j.key("theta").numbers(bins, [](const ReportBin& b) { return b.pose.theta; });
  j.close('}');
  j.key("errors");
  if (m.errors) {
    j.open('{');
    j.key("translation")
        .numbers(
            bins, [](const ReportBin& b) { return b.translation_error; }, 5);
    j.key("heading").numbers(
        bins, [](const ReportBin& b) { return b.heading_error; }, 5);
    j.close('}');
  } else {
    j.null();
  }
  j.key("speed").open('[');
  for (int i = 0; i < m.config.array.size(); ++i) {
    j.numbers(
        bins, [i](const ReportBin& b) { return b.speed[static_cast<std::size_t>(i)]; }, 5);
  }
  j.close(']');
  j.key("self_calibration");
  if (!m.self_calibration.empty()) {
    j.open('[');
    for (const ScaleSeries& c : m.self_calibration) {
      j.open('{');
      j.key("t").numbers(
          c.t, [](double v) { return v; }, kTimeDigits);
      j.key("scale_x").numbers(c.scale_x, [](double v) { return v; });
      j.key("scale_y").numbers(c.scale_y, [](double v) { return v; });
      j.close('}');
    }
    j.close(']');
  } else {
    j.null();
  }
  j.key("truth");
  if (!m.truth.empty()) {
    j.open('{');
    j.key("t").numbers(
        m.truth, [](const StampedPose& s) { return s.t; }, kTimeDigits);
    j.key("x").numbers(m.truth, [](const StampedPose& s) { return s.pose.t.x(); });
    j.key("y").numbers(m.truth, [](const StampedPose& s) { return s.pose.t.y(); });
    j.close('}');
  } else {
    j.null();
  }
  j.key("camera");
  if (!m.camera.empty()) {
    j.open('{');
    j.key("x").numbers(m.camera, [](const Eigen::Vector2d& p) { return p.x(); });
    j.key("y").numbers(m.camera, [](const Eigen::Vector2d& p) { return p.y(); });
    j.close('}');
  } else {
    j.null();
  }
  j.key("timeline");
  if (m.has_selection) {
    j.open('{');
    j.key("rows").open('[');
    for (const auto& name : m.config.names) j.string(name);
    if (has_source(m)) j.string("twist source");
    j.close(']');
    j.key("states").open('[');
    for (const auto& state : m.states) j.string(state);
    j.close(']');
    j.key("segments").open('[');
    for (const auto& s : m.timeline) {
      j.open('[').number(s.row).number(s.state);
      j.number(s.t0, kTimeDigits).number(s.t1, kTimeDigits).number(s.share, 3).close(']');
    }
    j.close(']');
    j.close('}');
  } else {
    j.null();
  }
  j.close('}');
  return j.text();
}

std::string percent(std::size_t part, std::size_t whole) {
  if (whole == 0) return "-";
  return fmt::format("{:.1f}%", 100.0 * static_cast<double>(part) / static_cast<double>(whole));
}

/// The gyro: where the heading came from (diagnostics.csv's imu rows).
std::string gyro_section(const ReportModel& m) {
  std::string s = "<section id=\"gyro\">\n<h2>Gyro</h2>\n";
  if (!m.gyro) {
    return s +
           "<p class=\"note\">The log has imu.csv. <code>--diagnostics DIAGNOSTICS.csv</code> "
           "(<code>moa odometry --diagnostics</code>) adds where each epoch's heading came "
           "from.</p>\n</section>\n";
  }
  const GyroCounts& g = *m.gyro;
  s += "<table class=\"summary\" id=\"gyro-table\">\n";
  const auto row = [&s](std::string_view name, const std::string& value) {
    s += fmt::format("<tr><th>{}</th><td>{}</td></tr>\n", name, value);
  };
  row("heading from the gyro",
      fmt::format("{} of {} epochs ({})", g.heading, g.epochs, percent(g.heading, g.epochs)));
  row("gyro readings", fmt::format("{} epochs: {} saturated, {} not used (inconsistent)",
                                   g.readings, g.saturated, g.inconsistent));
  row("test ratio", fmt::format("over 1 (the gate: the array's rotation disagreed) in {} epochs "
                                "({}), largest {:.3g}",
                                g.over_gate, percent(g.over_gate, g.readings), g.max_test));
  if (g.bias && g.scale) {
    row("calibration at the end",
        fmt::format("bias {:.6f} rad/s, scale {:.5f}", *g.bias, *g.scale));
  }
  s += "</table>\n";
  s += "<p>From the <code>imu</code> rows of diagnostics.csv: an epoch whose heading was not the "
       "gyro's took it from its twist's source (mice, wheels, hold). The calibration at the end "
       "is the gyro's bias and scale after the last epoch (its <code>bias</code> and "
       "<code>scale</code> columns; <code>moa odometry</code> prints them too, with their "
       "sd).</p>\n</section>\n";
  return s;
}

std::string summary_table(const ReportModel& m) {
  std::string t = "<table class=\"summary\">\n";
  const auto row = [&t](std::string_view name, const std::string& value) {
    t += fmt::format("<tr><th>{}</th><td>{}</td></tr>\n", name, value);
  };
  const ReportInputs& in = m.inputs;
  row("robot config", html(in.config.string()));
  row("log", html(in.log.string()));
  row("odometry", html(in.odometry.string()));
  if (in.truth) row("truth", html(in.truth->string()));
  if (in.calibration) row("calibration", html(in.calibration->string()));
  if (in.self_calibration) row("self-calibration", html(in.self_calibration->string()));
  if (in.diagnostics) row("diagnostics", html(in.diagnostics->string()));
  row("time span",
      fmt::format("{:.6g} s to {:.6g} s ({:.6g} s)", m.t_first, m.t_last, m.t_last - m.t_first));
  row("epochs", fmt::format("{}", m.epochs));
  row("path length", fmt::format("{:.4f} m (estimate)", m.distance));
  row("final pose", fmt::format("x {:.4f} m, y {:.4f} m, theta {:.4f} rad", m.final_pose.t.x(),
                                m.final_pose.t.y(), m.final_pose.theta));
  std::string sources;
  for (std::size_t s = 0; s < m.sources.size(); ++s) {
    if (m.sources[s] == 0) continue;
    sources += fmt::format("{}{} {}", sources.empty() ? "" : ", ", html(m.states[s]),
                           percent(m.sources[s], m.epochs));
  }
  if (!sources.empty()) row("twist source", sources);
  if (m.has_selection) row("run", html(m.summary.verdict()));
  if (m.camera_rows > 0) row("camera fixes", fmt::format("{}", m.camera_rows));
  if (m.errors) {
    const TrajectoryError& e = *m.errors;
    row("translation error", describe_translation(e));
    row("heading error", fmt::format("max {:.3g} deg, rms {:.3g} deg", to_degrees(e.max_heading),
                                     to_degrees(e.rms_heading)));
    if (m.floor) {
      t +=
          fmt::format("<tr class=\"verdict\"><th>verdict</th><td>{}</td></tr>\n",
                      html(verdict(e, {m.floor->max_translation, "the quantisation floor", true})));
    }
    row("compared with truth",
        fmt::format("{} epochs{}", e.samples,
                    e.outside > 0 ? fmt::format(" ({} outside the truth's time span)", e.outside)
                                  : std::string{}));
  }
  return t + "</table>\n";
}

std::string sensor_table(const ReportModel& m) {
  std::string t =
      "<table class=\"grid\">\n<tr><th>sensor</th><th>x (m)</th><th>y (m)</th><th>yaw "
      "(rad)</th><th>rated max speed (m/s)</th><th>largest point speed (m/s)</th><th>epochs "
      "over rated</th><th>used</th><th>excluded (reason: share of epochs)</th><th>mice.csv "
      "rows</th><th>lift rows</th><th>overflow rows</th><th>lowest SQUAL</th></tr>\n";
  for (int i = 0; i < m.config.array.size(); ++i) {
    const auto u = static_cast<std::size_t>(i);
    const SensorMount& mount = m.config.array[i];
    const SensorSummary& s = m.sensors[u];
    std::string excluded;
    for (std::size_t k = 0; k < s.excluded.size(); ++k) {
      if (s.excluded[k] == 0) continue;
      excluded += fmt::format("{}{}: {}", excluded.empty() ? "" : "<br>", html(m.states[k]),
                              percent(s.excluded[k], m.epochs));
    }
    t += fmt::format(
        "<tr><td>{}</td><td>{:.4f}</td><td>{:.4f}</td><td>{:.4f}</td><td>{}</td><td>{:.4f}</td>"
        "<td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
        html(m.config.names[u]), mount.position.x(), mount.position.y(), mount.yaw,
        mount.max_speed ? fmt::format("{:.4f}", *mount.max_speed) : "-", s.max_speed,
        mount.max_speed ? fmt::format("{} ({})", s.over_rated, percent(s.over_rated, m.epochs))
                        : "-",
        m.has_selection ? percent(s.used, m.epochs) : "-", excluded.empty() ? "-" : excluded,
        s.mice_rows, s.lift_rows, s.overflow_rows,
        s.min_squal ? fmt::format("{}", *s.min_squal) : "-");
  }
  return t + "</table>\n";
}

std::string calibration_table(const ReportModel& m) {
  const RobotConfig& cal = *m.calibrated;
  std::string t =
      "<table class=\"grid\">\n<tr><th>sensor</th><th>x (m)</th><th>y (m)</th><th>yaw "
      "(rad)</th><th>scale</th><th>mirrored</th><th>shift (mm)</th><th>yaw change "
      "(mrad)</th><th>scale change</th><th>latency (ms)</th></tr>\n";
  for (int i = 0; i < m.config.array.size(); ++i) {
    const SensorMount& a = m.config.array[i];
    const SensorMount& b = cal.array[i];
    const Eigen::Vector2d shift = (b.position - a.position) * 1e3;
    t += fmt::format(
        "<tr><td>{}</td><td>{:.4f} &rarr; {:.4f}</td><td>{:.4f} &rarr; {:.4f}</td><td>{:.4f} "
        "&rarr; {:.4f}</td><td>({:.4f}, {:.4f}) &rarr; ({:.4f}, "
        "{:.4f})</td><td>{}</td><td>({:+.2f}, "
        "{:+.2f}), |{:.2f}|</td><td>{:+.2f}</td><td>({:+.4f}, {:+.4f})</td><td>{:.2f} &rarr; "
        "{:.2f}</td></tr>\n",
        html(m.config.names[static_cast<std::size_t>(i)]), a.position.x(), b.position.x(),
        a.position.y(), b.position.y(), a.yaw, b.yaw, a.scale.x(), a.scale.y(), b.scale.x(),
        b.scale.y(),
        a.mirrored == b.mirrored
            ? std::string(a.mirrored ? "yes" : "no")
            : fmt::format("<strong>{} &rarr; {}</strong>", a.mirrored ? "yes" : "no",
                          b.mirrored ? "yes" : "no"),
        shift.x(), shift.y(), shift.norm(), wrap_angle(b.yaw - a.yaw) * 1e3,
        b.scale.x() - a.scale.x(), b.scale.y() - a.scale.y(), 1e3 * a.latency, 1e3 * b.latency);
  }
  t += "</table>\n";
  // The streams' latencies (s in the config; docs/formats/config.md, "Latencies").
  const auto latency = [](const std::optional<double>& x) {
    return x ? fmt::format("{:.2f} ms", 1e3 * *x) : std::string("not set");
  };
  for (const auto& [name, a, b] :
       {std::tuple{"camera", m.config.camera_latency, cal.camera_latency},
        std::tuple{"wheels", m.config.wheels_latency, cal.wheels_latency}}) {
    if (a || b) {
      t += fmt::format("<p>{} latency: {} &rarr; {}</p>\n", name, latency(a), latency(b));
    }
  }
  return t;
}

constexpr std::string_view kHint =
    "<p class=\"hint\">Drag a box to zoom, double-click to reset; click a legend entry to hide "
    "it; hover for values.</p>\n";

std::string chart(std::string_view id, std::string_view css_class, std::string_view style = {}) {
  return fmt::format("<div class=\"chart {}\"{}><canvas id=\"{}\"></canvas></div>\n", css_class,
                     style.empty() ? std::string{} : fmt::format(" style=\"{}\"", style), id);
}

}  // namespace

std::string render_report(const ReportModel& m) {
  std::string page;
  page += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  page += "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
  page += fmt::format("<title>{}</title>\n", html(m.title));
  page += "<style>\n" + report_assets::page_css() + "</style>\n";
  // First of all scripts, so that it also sees errors of the plotting library.
  page +=
      "<script>\n"
      "window.moaErrors = [];\n"
      "window.addEventListener('error', function (e) {\n"
      "  window.moaErrors.push(String(e.message || e));\n"
      "  var box = document.getElementById('moa-errors');\n"
      "  if (box) { box.textContent = window.moaErrors.join('\\n'); box.hidden = false; }\n"
      "});\n"
      "</script>\n</head>\n<body>\n";
  page += fmt::format("<header><h1>{}</h1>\n", html(m.title));
  if (!m.inputs.note.empty()) page += fmt::format("<p>{}</p>\n", html(m.inputs.note));
  page += "</header>\n";
  page += "<pre id=\"moa-errors\" class=\"errors\" hidden></pre>\n";
  page +=
      "<noscript><p class=\"note\">The plots need JavaScript; the tables do not.</p></noscript>\n";

  page += "<section id=\"summary\">\n<h2>Summary</h2>\n" + summary_table(m) + "</section>\n";

  page += "<section id=\"trajectory\">\n<h2>Trajectory</h2>\n";
  page +=
      "<p>World frame, metres. The estimate is the wide grey band with a dot every few points, "
      "the truth the dashed black line over it. The robot is drawn at a few times along the "
      "estimate with its sensors (dots, one colour per sensor on the whole page) and heading "
      "(line).</p>\n";
  page += chart("chart-trajectory", "square") + std::string(kHint) + "</section>\n";

  page += "<section id=\"errors\">\n<h2>Error against truth</h2>\n";
  if (m.errors) {
    page +=
        "<p>Translation error |p<sub>est</sub> &minus; p<sub>truth</sub>| (mm, left axis) and "
        "heading error |wrap(&theta;<sub>est</sub> &minus; &theta;<sub>truth</sub>)| (deg, right "
        "axis), truth interpolated at each epoch; the largest value in each time bin.</p>\n";
    page += chart("chart-errors", "wide") + std::string(kHint);
  } else {
    page +=
        "<p class=\"note\">No truth given: <code>--truth TRUTH.csv</code> adds this plot.</p>\n";
  }
  page += "</section>\n";

  page += "<section id=\"timeline\">\n<h2>Sensors used and excluded</h2>\n";
  if (m.has_selection) {
    page +=
        "<p>Per sensor, the state in most of each time bin's epochs: <em>used</em> in the "
        "estimate, or the reason it was left out (odometry.csv column <code>excluded</code>); "
        "the last row is the twist's source. Hover a bar for the share of its epochs in that "
        "state.</p>\n";
    const int rows = m.config.array.size() + (has_source(m) ? 1 : 0);
    page += chart("chart-timeline", "wide", fmt::format("height: {}px", 70 + 26 * rows)) +
            std::string(kHint);
  } else {
    page +=
        "<p class=\"note\">odometry.csv has no <code>used</code> and <code>excluded</code> "
        "columns.</p>\n";
  }
  page += "</section>\n";

  page += "<section id=\"speed\">\n<h2>Sensor speed against rated maximum</h2>\n";
  page +=
      "<p>Speed of each sensor's point over the floor, |v + &omega; J p<sub>i</sub>| from the "
      "odometry's twist and the config's mount (the largest in each time bin), and the rated "
      "<code>max_speed</code> (dashed).</p>\n";
  page += chart("chart-speed", "wide") + std::string(kHint) + "</section>\n";

  if (!m.self_calibration.empty()) {
    page += "<section id=\"self-calibration\">\n<h2>Self-calibration: scale over time</h2>\n";
    page +=
        "<p>Each sensor's scale estimated online (<code>moa odometry --self-calibration</code>, "
        "docs/self-calibration.md), relative to its configured resolution: 1 as configured; "
        "x axis solid, y axis dashed. An estimate is applied only where it differs from 1 by more "
        "than 3.29 of its standard deviations (docs/self-calibration.md, \"Applied\").</p>\n";
    page += chart("chart-self-calibration", "wide") + std::string(kHint) + "</section>\n";
  }

  if (m.has_imu || (m.gyro && m.gyro->readings > 0)) page += gyro_section(m);

  page += "<section id=\"sensors\">\n<h2>Sensors</h2>\n" + sensor_table(m) + "</section>\n";

  page += "<section id=\"layout\">\n";
  if (m.calibrated) {
    page += "<h2>Calibration: nominal and calibrated mounts</h2>\n";
    page +=
        "<p>Robot frame, metres: each sensor's position and x axis, nominal (ring, solid axis) "
        "and calibrated (dot, dashed axis). Calibration moves mounts by millimetres, so the "
        "changes are drawn magnified by the factors in the legend; the tooltips and the table "
        "give the true values.</p>\n";
  } else {
    page +=
        "<h2>Sensor layout</h2>\n<p>Robot frame, metres: each sensor's position and x axis.</p>\n";
  }
  page += chart("chart-layout", "square") + std::string(kHint);
  if (m.calibrated) {
    page += "<div id=\"calibration\">\n" + calibration_table(m) + "</div>\n";
  }
  page += "</section>\n";

  page += "<footer>Written by moa report. Plots: Chart.js (MIT licence), inlined.</footer>\n";
  page += "<script>\n" + report_assets::chart_js() + "\n</script>\n";
  page += "<script type=\"application/json\" id=\"moa-data\">" + data_json(m) + "</script>\n";
  page += "<script>\n" + report_assets::page_js() + "\n</script>\n";
  page += "</body>\n</html>\n";
  return page;
}

}  // namespace moa::io
