// Peak float arithmetic for SSE4.2 (4 lanes): built with -msse4.2 only, so no FMA exists; each
// round is a mulps and an addps per chain, 2 flops per lane. See include/lancer/peak.hpp.
#include <immintrin.h>

#include "lancer/peak.hpp"
#include "peak_kernels.hpp"

namespace lancer::peak_kernels {

double sse42_muladd(long iterations) {
  constexpr int N = kPeakChains;
  // a < 1: every chain converges to b / (1 - a) and stays normal (no denormal slow path).
  const __m128 a = _mm_set1_ps(0.999f), b = _mm_set1_ps(1e-3f);
  __m128 acc[N];
#pragma GCC unroll 16
  for (int k = 0; k < N; ++k) acc[k] = _mm_set1_ps(1.0f + 0.01f * k);
  for (long i = 0; i < iterations; ++i) {
#pragma GCC unroll 16
    for (int k = 0; k < N; ++k) acc[k] = _mm_add_ps(_mm_mul_ps(acc[k], a), b);
  }
  __m128 sum = acc[0];
  for (int k = 1; k < N; ++k) sum = _mm_add_ps(sum, acc[k]);
  sink = _mm_cvtss_f32(sum);
  return 2.0 * 4 * N * double(iterations);
}

}  // namespace lancer::peak_kernels
