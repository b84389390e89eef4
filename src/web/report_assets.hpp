// Internal to moa's I/O: the report page's assets, inlined into the library
// at build time (cmake/report_assets.cmake generates their definitions).
#pragma once

#include <string>

namespace moa::io::report_assets {

/// Chart.js 3, the minified UMD build of Debian's libjs-chart.js (MIT; its
/// copyright banner kept, the banner's web addresses left out).
std::string chart_js();
/// The page's own script (src/web/report_page.js): draws the charts.
std::string page_js();
/// The page's style sheet (src/web/report_page.css).
std::string page_css();

}  // namespace moa::io::report_assets
