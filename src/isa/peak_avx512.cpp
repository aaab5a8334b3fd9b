// Peak float arithmetic for AVX-512F (16 lanes): built with -mavx512f. One vfmadd on zmm per
// chain per round, 2 flops per lane; and the mul+add variant. See include/lancer/peak.hpp.
#include <immintrin.h>

#include "lancer/peak.hpp"
#include "peak_kernels.hpp"

namespace lancer::peak_kernels {

namespace {
template <bool kFma>
double run(long iterations) {
  constexpr int N = kPeakChainsAvx512;
  const __m512 a = _mm512_set1_ps(0.999f), b = _mm512_set1_ps(1e-3f);
  __m512 acc[N];
#pragma GCC unroll 16
  for (int k = 0; k < N; ++k) acc[k] = _mm512_set1_ps(1.0f + 0.01f * k);
  for (long i = 0; i < iterations; ++i) {
#pragma GCC unroll 16
    for (int k = 0; k < N; ++k)
      acc[k] = kFma ? _mm512_fmadd_ps(acc[k], a, b) : _mm512_add_ps(_mm512_mul_ps(acc[k], a), b);
  }
  __m512 sum = acc[0];
  for (int k = 1; k < N; ++k) sum = _mm512_add_ps(sum, acc[k]);
  alignas(64) float lanes[16];
  _mm512_store_ps(lanes, sum);
  float total = 0;
  for (float v : lanes) total += v;
  sink = total;
  return 2.0 * 16 * N * double(iterations);
}
}  // namespace

double avx512_fma(long iterations) { return run<true>(iterations); }
double avx512_muladd(long iterations) { return run<false>(iterations); }

}  // namespace lancer::peak_kernels
