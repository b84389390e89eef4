// Internal to moa's I/O: the dashboard page's own assets, inlined into the
// library at build time (cmake/dashboard.cmake). Chart.js is the report's
// (report_assets.hpp).
#pragma once

#include <string>

namespace moa::io::dashboard_assets {

/// The page's script (src/web/dashboard_page.js): the event stream and charts.
std::string page_js();
/// The page's style sheet (src/web/dashboard_page.css).
std::string page_css();

}  // namespace moa::io::dashboard_assets
