#pragma once

// What the CPU running the library can do, asked once per process: a kernel's version for a
// wider instruction set runs only where the CPU has it (the library is built for the baseline).

namespace cube {
namespace detail {

/// Whether this CPU runs AVX2 instructions (x86-64 built with GCC or Clang; false elsewhere).
/// Internal linkage: each kernel file keeps its own answer, read without a call or an indirection.
static inline bool cpuHasAvx2() {
#if defined(__x86_64__) && defined(__GNUC__)
  static const bool yes = __builtin_cpu_supports("avx2");
  return yes;
#else
  return false;
#endif
}

}  // namespace detail
}  // namespace cube
