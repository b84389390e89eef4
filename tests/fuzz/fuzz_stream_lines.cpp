// The lines of `moa live --streams` (CSV and JSON) through
// io::parse_stream_line, one per '\n'. A good line must give finite numbers and, for a fix with
// standard deviations, positive ones (what the recording's camera.csv must hold to replay); a bad
// line is an error value, never an exception. Any exception, any broken property, any sanitizer
// report is a finding.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>
#include <variant>

#include "moa/sources/stream_lines.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string_view text(reinterpret_cast<const char*>(data), size);
  while (!text.empty()) {
    const std::size_t end = std::min(text.find('\n'), text.size());
    const auto parsed = moa::io::parse_stream_line(text.substr(0, end));
    text.remove_prefix(std::min(end + 1, text.size()));
    const auto* row = std::get_if<moa::io::StreamRow>(&parsed);
    if (row == nullptr) continue;
    if (const auto* w = std::get_if<moa::io::WheelRow>(&row->row)) {
      if (!std::isfinite(w->t) || !w->twist.v.allFinite() || !std::isfinite(w->twist.omega)) {
        std::abort();
      }
    } else if (const auto* g = std::get_if<moa::io::ImuRow>(&row->row)) {
      if (!std::isfinite(g->t) || !std::isfinite(g->gz)) std::abort();
    } else {
      const auto& f = std::get<moa::CameraFix>(row->row);
      if (!std::isfinite(f.t) || !f.position.allFinite()) std::abort();
      if (f.theta && !std::isfinite(*f.theta)) std::abort();
      if (f.sigma && !(f.sigma->x() > 0.0 && f.sigma->y() > 0.0 && f.sigma->allFinite())) {
        std::abort();
      }
    }
  }
  return 0;
}
