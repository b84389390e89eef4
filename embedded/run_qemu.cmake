# cmake -DBINARY_DIR=... [-DFLOAT_BINARY_DIR=...] -DMOA=moa -DSTREAM=qemu_stream
#       -DQEMU=qemu-system-arm -DWORK_DIR=... -P run_qemu.cmake
# The test embedded_qemu_odometry: the library pipeline (moa::Odometry) run on
# an emulated Cortex-M4F against the host's `moa odometry` on the same log.
#  1. brings the Cortex-M4F builds up to date: BINARY_DIR (the core in
#     double, as on the host) and FLOAT_BINARY_DIR if given (MOA_M4F_SCALAR=float);
#  2. simulates logs on the host (`moa simulate --scenario faults-dirty`:
#     four HDNS-2051 sensors, 17 s at 100 Hz, a dirty floor patch, wheels and
#     camera; and faults-drift for the self-calibration);
#  3. per case (estimator, options): `moa odometry` writes odometry.csv;
#     `qemu_stream pack` packs the log for the device; QEMU runs
#     odometry_qemu.elf on mps2-an386 (Cortex-M4 with FPU) under -icount
#     shift=0 (1 instruction = 1 ns of virtual time) with semihosting; and
#     `qemu_stream compare` checks the device's steps against odometry.csv and
#     prints the instructions per step the device counted; each case runs
#     with both builds.
#
# Tolerance: the device and the host both compute in IEEE binary64 from the
# same source, so the results are nearly exact. What differs: Eigen's SSE2
# kernels on the host against scalar code on the M4F (summation order) and
# glibc's libm against newlib's (sin, cos, exp, log, within an ulp or so); each
# changes a result by a few units in the last place (u = 2^-53 = 1.1e-16). A
# twist is some 100 operations from the counts through a least-squares solve
# whose condition number is about 10 for these arrays: relative error below
# 10 * 100 * u = 1e-13, and the twists are below 1 m/s and 1 rad/s. A pose
# sums 1702 steps of twist * dt (dt = 0.01 s): below 1702 * 0.01 * 1e-13 =
# 1.7e-15 m from the twists, plus the heading's error times the distance
# (about 1 m). 1e-12 (m, rad, m/s, rad/s) covers that with margin and is
# nine orders of magnitude below one count (32 um at 800 cpi); the epoch
# times and the sensors each estimate used must be identical.
set(double_pose_tolerance 1e-12)
set(double_twist_tolerance 1e-12)
# The float core against the host's doubles: the same argument with float's
# u = 2^-24 = 6e-8 gives twists within 10 * 100 * u = 6e-5 (relative, and
# absolute below 1 m/s); the pose adds one float rounding of its ~1 m
# coordinates per step, 1702 * 6e-8 = 1e-4 m at worst (times stay double in
# both, so the epochs are the same). 1e-4 m (rad, m/s, rad/s) is 3 counts and
# 1/85 of this log's odometry error against the truth (8.6 mm); the sensors
# used must still be the same.
set(float_pose_tolerance 1e-4)
set(float_twist_tolerance 1e-4)
# mps2-an386 clocks the SysTick at 25 MHz: one tick is 40 ns, 40 instructions.
set(instructions_per_tick 40)

foreach(var BINARY_DIR MOA STREAM QEMU WORK_DIR)
  if(NOT ${var})
    message(FATAL_ERROR "run_qemu.cmake: -D${var}= is required")
  endif()
endforeach()

set(scalars double)
set(double_elf ${BINARY_DIR}/odometry_qemu.elf)
if(FLOAT_BINARY_DIR)
  list(APPEND scalars float)
  set(float_elf ${FLOAT_BINARY_DIR}/odometry_qemu.elf)
endif()
foreach(dir ${BINARY_DIR} ${FLOAT_BINARY_DIR})
  execute_process(COMMAND ${CMAKE_COMMAND} --build ${dir} --target odometry_qemu
                  RESULT_VARIABLE built)
  if(NOT built EQUAL 0)
    message(FATAL_ERROR "building ${dir} failed")
  endif()
endforeach()

file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
foreach(scenario faults-dirty faults-drift)
  execute_process(COMMAND ${MOA} simulate --scenario ${scenario} --seed 1
                          --out ${WORK_DIR}/${scenario} --quiet COMMAND_ERROR_IS_FATAL ANY)
endforeach()

# name; scenario; flags of `moa odometry` and `qemu_stream pack`. The online
# self-calibration on faults-drift, where m2's scale falls by 10 % and its
# correction is applied (docs/self-calibration.md).
set(cases
    "consensus\;faults-dirty\;--estimator\;consensus"
    "sekimori\;faults-dirty\;--estimator\;sekimori"
    "ls\;faults-dirty\;--estimator\;ls"
    "consensus-camera\;faults-dirty\;--estimator\;consensus\;--fuse-camera"
    "consensus-self-calibration\;faults-drift\;--estimator\;consensus\;--self-calibrate")
foreach(case IN LISTS cases)
  list(POP_FRONT case name)
  list(POP_FRONT case scenario)
  set(log ${WORK_DIR}/${scenario})
  set(dir ${WORK_DIR}/${name})
  file(MAKE_DIRECTORY ${dir})
  execute_process(COMMAND ${MOA} odometry --config ${log}/robot.yaml --log ${log} ${case}
                          --out ${dir}/odometry.csv --quiet COMMAND_ERROR_IS_FATAL ANY)
  execute_process(COMMAND ${STREAM} pack ${log}/robot.yaml ${log} ${dir}/in.bin ${case}
                  COMMAND_ERROR_IS_FATAL ANY)
  foreach(scalar ${scalars})
    # The device's console (semihosting) is QEMU's stdout; a fault or an
    # error ends the emulation with status 1; TIMEOUT guards against a hang.
    set(tag "${name}, ${scalar}")
    execute_process(
      COMMAND
        ${QEMU} -machine mps2-an386 -cpu cortex-m4 -nographic -monitor none -serial null
        -semihosting-config
        enable=on,target=native,arg=odometry_qemu,arg=in.bin,arg=${scalar}.bin -icount shift=0
        -kernel ${${scalar}_elf}
      WORKING_DIRECTORY ${dir}
      RESULT_VARIABLE ran
      OUTPUT_VARIABLE console
      ERROR_VARIABLE console
      TIMEOUT 120)
    string(STRIP "${console}" console)
    message("[${tag}] ${console}")
    if(NOT ran EQUAL 0)
      message(FATAL_ERROR "[${tag}] QEMU: ${ran}")
    endif()
    if(name STREQUAL "consensus-self-calibration" AND scalar STREQUAL "float")
      # The self-calibration decides by thresholds (a deadband crossed, a
      # block gated, a correction renewed): in float one of them falls a
      # block earlier or later than in the host's doubles (on this log at
      # 2.1 s, then the poses differ by up to 4.7 mm), so the float device
      # is run (no fault, its instructions and stack reported) but not held
      # to the host's odometry.csv; the double device is, to 1e-12.
      message("[${tag}] ran; not compared with the host's doubles (thresholds)")
      continue()
    endif()
    execute_process(
      COMMAND ${STREAM} compare ${log}/robot.yaml ${dir}/odometry.csv ${dir}/${scalar}.bin
              ${${scalar}_pose_tolerance} ${${scalar}_twist_tolerance} ${instructions_per_tick}
      RESULT_VARIABLE compared
      OUTPUT_VARIABLE report
      ERROR_VARIABLE report)
    string(STRIP "${report}" report)
    message("[${tag}] ${report}")
    if(NOT compared EQUAL 0)
      message(FATAL_ERROR "[${tag}] the device's steps differ from odometry.csv")
    endif()
  endforeach()
endforeach()
