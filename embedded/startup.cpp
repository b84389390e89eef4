// Reset and the Cortex-M4 core vector table: the minimum that lets the
// program run from flash. No interrupt of the part is used, so the table
// stops after the 16 core entries.
#include <cstdint>

extern "C" {
// From stm32f4.ld.
extern std::uint32_t __data_start[], __data_end[], __data_load[];
extern std::uint32_t __bss_start[], __bss_end[];
extern std::uint32_t __stack_top[];
using InitFunction = void (*)();
extern InitFunction __init_array_start[], __init_array_end[];

[[noreturn]] void moa_m4f_main();
[[noreturn]] void reset_handler();
void default_handler();
}

namespace {
// Coprocessor Access Control Register: full access to CP10 and CP11 (the
// FPU), which is off at reset; any floating-point instruction faults before.
volatile std::uint32_t& cpacr() { return *reinterpret_cast<volatile std::uint32_t*>(0xE000ED88u); }
}  // namespace

extern "C" [[noreturn]] void reset_handler() {
  cpacr() = cpacr() | (0xFu << 20);
  asm volatile("dsb\n\tisb" ::: "memory");
  for (std::uint32_t *src = __data_load, *dst = __data_start; dst < __data_end;) *dst++ = *src++;
  for (std::uint32_t* dst = __bss_start; dst < __bss_end;) *dst++ = 0;
  for (InitFunction* f = __init_array_start; f < __init_array_end; ++f) (*f)();
  moa_m4f_main();
}

// Weak: a program may end the run instead (odometry_qemu.cpp, under QEMU).
extern "C" __attribute__((weak)) void default_handler() {
  for (;;) {
  }
}

using Vector = void (*)();
// Entry 0 is the initial stack pointer, the others are handlers.
extern "C" __attribute__((section(".isr_vector"), used)) const Vector kVectorTable[16] = {
    reinterpret_cast<Vector>(__stack_top),
    reset_handler,    // reset
    default_handler,  // NMI
    default_handler,  // hard fault
    default_handler,  // memory management fault
    default_handler,  // bus fault
    default_handler,  // usage fault
    nullptr,
    nullptr,
    nullptr,
    nullptr,
    default_handler,  // SVCall
    default_handler,  // debug monitor
    nullptr,
    default_handler,  // PendSV
    default_handler,  // SysTick
};
