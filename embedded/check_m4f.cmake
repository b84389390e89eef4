# cmake -DBINARY_DIR=... -DLINKER_SCRIPT=... -DSIZE=arm-none-eabi-size
#       -DNM=arm-none-eabi-nm -P check_m4f.cmake
# Brings the Cortex-M4F build up to date, prints its sizes and checks that
# text + data fit the flash, data + bss fit the RAM and the stack fits the
# CCM of stm32f4.ld, and that no allocator, exception or RTTI symbol is linked.
execute_process(COMMAND ${CMAKE_COMMAND} --build ${BINARY_DIR} RESULT_VARIABLE built)
if(NOT built EQUAL 0)
  message(FATAL_ERROR "building ${BINARY_DIR} failed")
endif()
set(elf ${BINARY_DIR}/consensus_m4f.elf)

file(READ ${LINKER_SCRIPT} script)
foreach(region FLASH RAM CCM)
  if(NOT script MATCHES "${region} +\\([a-z]+\\) *: *ORIGIN = 0x[0-9A-Fa-f]+, LENGTH = ([0-9]+)K")
    message(FATAL_ERROR "${LINKER_SCRIPT}: no ${region} region")
  endif()
  math(EXPR ${region}_bytes "${CMAKE_MATCH_1} * 1024")
endforeach()

execute_process(COMMAND ${SIZE} ${elf} OUTPUT_VARIABLE berkeley COMMAND_ERROR_IS_FATAL ANY)
execute_process(COMMAND ${SIZE} -A ${elf} OUTPUT_VARIABLE sysv COMMAND_ERROR_IS_FATAL ANY)
message("${berkeley}${sysv}")
string(REGEX MATCH "\n *([0-9]+)[ \t]+([0-9]+)[ \t]+([0-9]+)" row "${berkeley}")
if(NOT row)
  message(FATAL_ERROR "cannot read the output of ${SIZE}")
endif()
set(text ${CMAKE_MATCH_1})
set(data ${CMAKE_MATCH_2})
set(bss ${CMAKE_MATCH_3})
# The stack is a section of its own (System V format: name, size, address),
# counted in the Berkeley format's bss but placed in the CCM.
if(NOT sysv MATCHES "\n\\.stack[ \t]+([0-9]+)")
  message(FATAL_ERROR "no .stack section in ${elf}")
endif()
set(stack ${CMAKE_MATCH_1})
math(EXPR bss "${bss} - ${stack}")
math(EXPR flash "${text} + ${data}")
math(EXPR ram "${data} + ${bss}")
message("flash (text + data): ${flash} of ${FLASH_bytes} bytes; "
        "RAM (data + bss): ${ram} of ${RAM_bytes} bytes; "
        "CCM (the main stack): ${stack} of ${CCM_bytes} bytes")
if(flash GREATER FLASH_bytes)
  message(FATAL_ERROR "the program does not fit the flash")
endif()
if(ram GREATER RAM_bytes)
  message(FATAL_ERROR "the program does not fit the RAM")
endif()
if(stack GREATER CCM_bytes)
  message(FATAL_ERROR "the stack does not fit the CCM")
endif()

# Allocators (C and C++), the system break, exceptions and RTTI.
execute_process(COMMAND ${NM} ${elf} OUTPUT_VARIABLE symbols COMMAND_ERROR_IS_FATAL ANY)
set(forbidden "")
foreach(pattern malloc calloc realloc free _malloc_r _calloc_r _realloc_r _free_r _sbrk _sbrk_r
                "_Zn[wa].*" "_Zd[la].*" "__cxa_.*" "__gxx_personality.*" "_Unwind_.*" "_ZTI.*")
  string(REGEX MATCHALL "[ \t](${pattern})\n" found "${symbols}")
  list(APPEND forbidden ${found})
endforeach()
if(forbidden)
  string(STRIP "${forbidden}" forbidden)
  message(FATAL_ERROR "linked, but must not be: ${forbidden}")
endif()
message("no heap, exception or RTTI symbol linked")
