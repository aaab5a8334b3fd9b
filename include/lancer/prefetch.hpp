// Starting loads early: the one way lancer asks for cache lines ahead of use.
#pragma once

#include <cstddef>

namespace lancer {

// Starts loading the lines of `bytes` bytes at p (a node or a leaf a walk will reach, a record a
// hit will read). GCC (12) finds a function that only prefetches "pure" and deletes the calls to
// it that it has not inlined early, prefetches and all (the lone walks had none): the empty
// volatile asm is a side effect that keeps every caller's prefetches, however it is inlined.
[[gnu::always_inline]] inline void prefetch_lines(const void* p, std::size_t bytes) noexcept {
  const char* c = static_cast<const char*>(p);
  for (std::size_t b = 0; b < bytes; b += 64) __builtin_prefetch(c + b);
  asm volatile("" : : "r"(c));
}

}  // namespace lancer
