# Included by the root CMakeLists.txt (MOA_BUILD_EMBEDDED): builds embedded/,
# moa's core cross-compiled for a Cortex-M4F, as a project of its own with
# its own toolchain (the host's flags, sanitizers included, stay out), and
# the test that checks the program fits the part and links no heap.
include(ExternalProject)

foreach(tool arm-none-eabi-g++ arm-none-eabi-size arm-none-eabi-nm)
  string(MAKE_C_IDENTIFIER "MOA_${tool}" var)
  find_program(${var} ${tool})
  if(NOT ${var})
    message(FATAL_ERROR "${tool} not found: install gcc-arm-none-eabi libnewlib-arm-none-eabi "
                        "libstdc++-arm-none-eabi-newlib (make deps), or configure with "
                        "-DMOA_BUILD_EMBEDDED=OFF")
  endif()
endforeach()

set(MOA_M4F_BINARY_DIR ${PROJECT_BINARY_DIR}/embedded)
ExternalProject_Add(
  moa_m4f
  SOURCE_DIR ${PROJECT_SOURCE_DIR}/embedded
  BINARY_DIR ${MOA_M4F_BINARY_DIR}
  CMAKE_ARGS -DCMAKE_TOOLCHAIN_FILE=${PROJECT_SOURCE_DIR}/embedded/cortex-m4f.cmake
             -DMOA_WARNINGS_AS_ERRORS=${MOA_WARNINGS_AS_ERRORS} -DEigen3_DIR=${Eigen3_DIR}
  BUILD_ALWAYS TRUE
  INSTALL_COMMAND ""
  BUILD_BYPRODUCTS ${MOA_M4F_BINARY_DIR}/consensus_m4f.elf ${MOA_M4F_BINARY_DIR}/odometry_qemu.elf)

# The same programs with the core in single precision (MOA_M4F_SCALAR=float,
# include/moa/core/real.hpp), for the M4F's float-only FPU.
set(MOA_M4F_FLOAT_BINARY_DIR ${PROJECT_BINARY_DIR}/embedded-float)
ExternalProject_Add(
  moa_m4f_float
  SOURCE_DIR ${PROJECT_SOURCE_DIR}/embedded
  BINARY_DIR ${MOA_M4F_FLOAT_BINARY_DIR}
  CMAKE_ARGS -DCMAKE_TOOLCHAIN_FILE=${PROJECT_SOURCE_DIR}/embedded/cortex-m4f.cmake
             -DMOA_WARNINGS_AS_ERRORS=${MOA_WARNINGS_AS_ERRORS} -DEigen3_DIR=${Eigen3_DIR}
             -DMOA_M4F_SCALAR=float
  BUILD_ALWAYS TRUE
  INSTALL_COMMAND ""
  BUILD_BYPRODUCTS ${MOA_M4F_FLOAT_BINARY_DIR}/consensus_m4f.elf
                   ${MOA_M4F_FLOAT_BINARY_DIR}/odometry_qemu.elf)

# The pipeline on an emulated Cortex-M4F (run_qemu.cmake), where Debian's
# qemu-system-arm is installed (make deps installs it).
find_program(MOA_QEMU_SYSTEM_ARM qemu-system-arm)
if(MOA_BUILD_TESTS AND NOT MOA_QEMU_SYSTEM_ARM)
  message(STATUS "qemu-system-arm not found: the test embedded_qemu_odometry (the Cortex-M4F "
                 "program under QEMU) is not registered; install qemu-system-arm (make deps)")
endif()

if(MOA_BUILD_TESTS)
  add_test(NAME embedded_m4f_fits_without_heap
           COMMAND ${CMAKE_COMMAND} -DBINARY_DIR=${MOA_M4F_BINARY_DIR}
                   -DLINKER_SCRIPT=${PROJECT_SOURCE_DIR}/embedded/stm32f4.ld
                   -DSIZE=${MOA_arm_none_eabi_size} -DNM=${MOA_arm_none_eabi_nm}
                   -P ${PROJECT_SOURCE_DIR}/embedded/check_m4f.cmake)
  # Both tests build ${MOA_M4F_BINARY_DIR} first: one at a time.
  set_tests_properties(embedded_m4f_fits_without_heap PROPERTIES LABELS embedded TIMEOUT 600
                                                                 RESOURCE_LOCK moa_m4f_build)
  if(MOA_QEMU_SYSTEM_ARM)
    add_test(NAME embedded_qemu_odometry
             COMMAND ${CMAKE_COMMAND} -DBINARY_DIR=${MOA_M4F_BINARY_DIR}
                     -DFLOAT_BINARY_DIR=${MOA_M4F_FLOAT_BINARY_DIR} -DMOA=$<TARGET_FILE:moa_cli>
                     -DSTREAM=$<TARGET_FILE:qemu_stream> -DQEMU=${MOA_QEMU_SYSTEM_ARM}
                     -DWORK_DIR=${CMAKE_CURRENT_BINARY_DIR}/embedded_qemu
                     -P ${PROJECT_SOURCE_DIR}/embedded/run_qemu.cmake)
    set_tests_properties(embedded_qemu_odometry PROPERTIES LABELS embedded TIMEOUT 600
                                                           RESOURCE_LOCK moa_m4f_build)
  endif()
endif()
