// A cheap monotonic tick count for the stage profile: the time-stamp counter on x86-64 (cycles
// at the nominal rate), the virtual counter on aarch64 (a fixed-rate timer, not cycles: the
// profile converts ticks to seconds by the same run's wall time either way).
#pragma once

#include <cstdint>

namespace lancer {

inline std::uint64_t ticks() noexcept {
#if defined(__x86_64__) || defined(__i386__)
  return __builtin_ia32_rdtsc();
#elif defined(__aarch64__)
  std::uint64_t t;
  asm volatile("mrs %0, cntvct_el0" : "=r"(t));
  return t;
#else
#error "lancer's stage profile needs a tick counter for this architecture"
#endif
}

}  // namespace lancer
