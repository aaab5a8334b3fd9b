// Peak float arithmetic for AVX2 (8 lanes): built with -mavx2 -mfma. One vfmadd per chain per
// round, 2 flops per lane; and the mul+add variant lancer's -ffp-contract=off code is limited to.
// See include/lancer/peak.hpp.
#include <immintrin.h>

#include "lancer/peak.hpp"
#include "peak_kernels.hpp"

namespace lancer::peak_kernels {

namespace {
template <bool kFma>
double run(long iterations) {
  constexpr int N = kPeakChains;
  const __m256 a = _mm256_set1_ps(0.999f), b = _mm256_set1_ps(1e-3f);
  __m256 acc[N];
#pragma GCC unroll 16
  for (int k = 0; k < N; ++k) acc[k] = _mm256_set1_ps(1.0f + 0.01f * k);
  for (long i = 0; i < iterations; ++i) {
#pragma GCC unroll 16
    for (int k = 0; k < N; ++k)
      acc[k] = kFma ? _mm256_fmadd_ps(acc[k], a, b) : _mm256_add_ps(_mm256_mul_ps(acc[k], a), b);
  }
  __m256 sum = acc[0];
  for (int k = 1; k < N; ++k) sum = _mm256_add_ps(sum, acc[k]);
  sink = _mm256_cvtss_f32(sum);
  return 2.0 * 8 * N * double(iterations);
}
}  // namespace

double avx2_fma(long iterations) { return run<true>(iterations); }
double avx2_muladd(long iterations) { return run<false>(iterations); }

}  // namespace lancer::peak_kernels
