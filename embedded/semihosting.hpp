// Arm semihosting (the "Semihosting for AArch32 and AArch64" specification):
// the debugger, here QEMU with -semihosting-config enable=on,target=native,
// serves file and console calls the program makes with `bkpt 0xAB`, r0 the
// operation, r1 the argument block. Only what odometry_qemu.cpp needs; no
// newlib (its rdimon stdio would allocate).
#pragma once

#include <cstddef>
#include <cstdint>

namespace moa::semihosting {

enum class Op : std::uint32_t {
  kOpen = 0x01,
  kClose = 0x02,
  kWrite0 = 0x04,  ///< a NUL-terminated string to the console
  kWrite = 0x05,
  kRead = 0x06,
  kGetCmdline = 0x15,
  kExit = 0x18,
};

inline std::int32_t call(Op op, const void* argument) {
  register std::uint32_t r0 asm("r0") = static_cast<std::uint32_t>(op);
  register const void* r1 asm("r1") = argument;
  asm volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
  return static_cast<std::int32_t>(r0);
}

/// Modes of SYS_OPEN (the ISO C fopen modes, in this order).
inline constexpr std::uint32_t kReadBinary = 1;   // "rb"
inline constexpr std::uint32_t kWriteBinary = 5;  // "wb"

/// A host file handle, or -1.
inline std::int32_t open(const char* path, std::uint32_t mode) {
  std::size_t length = 0;
  while (path[length] != '\0') ++length;
  const std::uint32_t block[3] = {
      static_cast<std::uint32_t>(reinterpret_cast<std::uintptr_t>(path)), mode,
      static_cast<std::uint32_t>(length)};
  return call(Op::kOpen, block);
}

inline void close(std::int32_t handle) {
  const std::uint32_t block[1] = {static_cast<std::uint32_t>(handle)};
  (void)call(Op::kClose, block);
}

/// Bytes read (fewer than `size` at the end of the file).
inline std::size_t read(std::int32_t handle, void* buffer, std::size_t size) {
  const std::uint32_t block[3] = {
      static_cast<std::uint32_t>(handle),
      static_cast<std::uint32_t>(reinterpret_cast<std::uintptr_t>(buffer)),
      static_cast<std::uint32_t>(size)};
  const std::int32_t not_read = call(Op::kRead, block);  // bytes not read
  return not_read < 0 ? 0 : size - static_cast<std::size_t>(not_read);
}

/// True when every byte was written.
inline bool write(std::int32_t handle, const void* data, std::size_t size) {
  const std::uint32_t block[3] = {
      static_cast<std::uint32_t>(handle),
      static_cast<std::uint32_t>(reinterpret_cast<std::uintptr_t>(data)),
      static_cast<std::uint32_t>(size)};
  return call(Op::kWrite, block) == 0;
}

inline void print(const char* text) { (void)call(Op::kWrite0, text); }

/// The command line QEMU passes (-semihosting-config arg=..., else the
/// -kernel file name), NUL-terminated in `buffer`; false when it does not fit.
inline bool command_line(char* buffer, std::size_t size) {
  std::uint32_t block[2] = {static_cast<std::uint32_t>(reinterpret_cast<std::uintptr_t>(buffer)),
                            static_cast<std::uint32_t>(size)};
  return call(Op::kGetCmdline, block) == 0;
}

/// Ends the emulation: QEMU exits with status 0 on success, 1 otherwise.
[[noreturn]] inline void exit(bool success) {
  // ADP_Stopped_ApplicationExit, or ADP_Stopped_RunTimeErrorUnknown. On
  // AArch32 the reason is r1 itself, not a block.
  const std::uintptr_t reason = success ? 0x20026 : 0x20023;
  (void)call(Op::kExit, reinterpret_cast<const void*>(reason));
  for (;;) {
  }
}

}  // namespace moa::semihosting
