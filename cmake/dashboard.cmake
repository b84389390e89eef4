# The live dashboard (moa live --serve, include/moa/web/dashboard.hpp):
# Debian's cpp-httplib (libcpp-httplib-dev: a header and a shared library,
# built with OpenSSL, zlib and Brotli support, so its flags come from
# pkg-config), and the page's script and style sheet inlined into libmoa_web as
# the report page's are (Chart.js comes from the report's assets).
find_package(PkgConfig REQUIRED)
pkg_check_modules(MOA_HTTPLIB REQUIRED cpp-httplib)
find_package(Threads REQUIRED)
set_source_files_properties(${PROJECT_SOURCE_DIR}/src/web/dashboard.cpp PROPERTIES COMPILE_OPTIONS
                                                                                 "${MOA_HTTPLIB_CFLAGS_OTHER}")
target_include_directories(moa_web SYSTEM PRIVATE ${MOA_HTTPLIB_INCLUDE_DIRS})
target_link_libraries(moa_web PRIVATE ${MOA_HTTPLIB_LINK_LIBRARIES} Threads::Threads)

set(MOA_DASHBOARD_ASSETS_CPP ${PROJECT_BINARY_DIR}/generated/dashboard_assets.cpp)
add_custom_command(
  OUTPUT ${MOA_DASHBOARD_ASSETS_CPP}
  COMMAND ${CMAKE_COMMAND} -DOUTPUT=${MOA_DASHBOARD_ASSETS_CPP} -DNAMESPACE=dashboard_assets
          -DHEADER=dashboard_assets.hpp -DPAGE_JS=${PROJECT_SOURCE_DIR}/src/web/dashboard_page.js
          -DPAGE_CSS=${PROJECT_SOURCE_DIR}/src/web/dashboard_page.css
          -P ${PROJECT_SOURCE_DIR}/cmake/embed_report_assets.cmake
  DEPENDS ${PROJECT_SOURCE_DIR}/src/web/dashboard_page.js
          ${PROJECT_SOURCE_DIR}/src/web/dashboard_page.css
          ${PROJECT_SOURCE_DIR}/cmake/embed_report_assets.cmake
  COMMENT "Inlining the dashboard page's assets (dashboard_page.js, dashboard_page.css)"
  VERBATIM)
target_sources(moa_web PRIVATE ${MOA_DASHBOARD_ASSETS_CPP})
