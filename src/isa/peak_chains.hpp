// The peak-arithmetic kernel, one source for every ISA: include only from src/isa/peak_*.cpp,
// which are built with that ISA's flags and instantiate it.
#pragma once

#include <xsimd/xsimd.hpp>

#include "lancer/packet/fused.hpp"
#include "peak_kernels.hpp"

namespace lancer::peak_kernels {

template <class Arch, bool kFma, int N>
double chains(long iterations) {
  using B = xsimd::batch<float, Arch>;
  // a < 1: every chain converges to b / (1 - a) and stays normal (no denormal slow path).
  const B a(0.999f), b(1e-3f);
  B acc[N];
#pragma GCC unroll 16
  for (int k = 0; k < N; ++k) acc[k] = B(1.0f + 0.01f * k);
  for (long i = 0; i < iterations; ++i) {
#pragma GCC unroll 16
    for (int k = 0; k < N; ++k) acc[k] = kFma ? packet::fmadd(acc[k], a, b) : acc[k] * a + b;
  }
  B sum = acc[0];
  for (int k = 1; k < N; ++k) sum = sum + acc[k];
  sink = sum.get(0);
  return 2.0 * double(B::size) * N * double(iterations);
}

}  // namespace lancer::peak_kernels
