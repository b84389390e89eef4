# The report page's assets (moa report, include/moa/web/report.hpp), inlined
# into libmoa_web at build time: Chart.js from Debian's libjs-chart.js (`make
# deps` installs it), and the page's own script and style sheet. Nothing is
# downloaded, and the page references nothing outside itself.
find_file(MOA_CHARTJS chart.min.js PATHS /usr/share/javascript/chart.js NO_DEFAULT_PATH
          DOC "Chart.js 3 minified UMD build (Debian: libjs-chart.js)")
if(NOT MOA_CHARTJS)
  message(FATAL_ERROR "chart.min.js not found: install Debian's libjs-chart.js (make deps), "
                      "or pass -DMOA_CHARTJS=/path/to/chart.min.js (Chart.js 3)")
endif()

set(MOA_REPORT_ASSETS_CPP ${PROJECT_BINARY_DIR}/generated/report_assets.cpp)
add_custom_command(
  OUTPUT ${MOA_REPORT_ASSETS_CPP}
  COMMAND ${CMAKE_COMMAND} -DOUTPUT=${MOA_REPORT_ASSETS_CPP} -DCHART_JS=${MOA_CHARTJS}
          -DPAGE_JS=${PROJECT_SOURCE_DIR}/src/web/report_page.js
          -DPAGE_CSS=${PROJECT_SOURCE_DIR}/src/web/report_page.css
          -P ${PROJECT_SOURCE_DIR}/cmake/embed_report_assets.cmake
  DEPENDS ${MOA_CHARTJS} ${PROJECT_SOURCE_DIR}/src/web/report_page.js
          ${PROJECT_SOURCE_DIR}/src/web/report_page.css
          ${PROJECT_SOURCE_DIR}/cmake/embed_report_assets.cmake
  COMMENT "Inlining the report page's assets (Chart.js, report_page.js, report_page.css)"
  VERBATIM)
target_sources(moa_web PRIVATE ${MOA_REPORT_ASSETS_CPP})
