# moa::core, the heap-free per-sample layer (src/core): defined once here and
# included by the host build (CMakeLists.txt) and by the Cortex-M4F build
# (embedded/CMakeLists.txt), so the microcontroller links exactly this target.
# Eigen only: no I/O, no exceptions from per-sample calls, no allocation.
get_filename_component(MOA_CORE_ROOT ${CMAKE_CURRENT_LIST_DIR}/.. ABSOLUTE)
file(GLOB MOA_CORE_SOURCES CONFIGURE_DEPENDS ${MOA_CORE_ROOT}/src/core/*.cpp)
add_library(moa_core STATIC ${MOA_CORE_SOURCES})
add_library(moa::core ALIAS moa_core)
target_include_directories(moa_core PUBLIC $<BUILD_INTERFACE:${MOA_CORE_ROOT}/include>
                                           $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
target_link_libraries(moa_core PUBLIC Eigen3::Eigen)
