// A batch mask as one bit per lane (xsimd 8.1 has no mask()), for kernel.hpp and traverse.hpp.
// Include only from code built for the batch's ISA.
#pragma once

#include <cstddef>
#include <type_traits>
#include <xsimd/xsimd.hpp>

#include "lancer/packet/intrin.hpp"
#include "lancer/prefetch.hpp"

namespace lancer::packet {

// AVX-512 masks already are bits; SSE and AVX masks are vectors whose sign bits movemask
// collects.
template <class T, class Arch>
unsigned lane_bits(const xsimd::batch_bool<T, Arch>& m) noexcept {
  using R = typename xsimd::batch_bool<T, Arch>::register_type;
  const R r = static_cast<R>(m);
  constexpr bool kFloat = std::is_same_v<T, float>;
  // By the batch's size, not R's type: naming a vector type as a template argument drops its
  // attributes (-Wignored-attributes).
  constexpr std::size_t kBytes = sizeof(xsimd::batch<T, Arch>);
  if constexpr (kBytes == 64)  // AVX-512: masks are __mmask16 / __mmask8
    return static_cast<unsigned>(r);
  else if constexpr (kBytes == 16)
    return static_cast<unsigned>(kFloat ? _mm_movemask_ps(__m128(r)) : _mm_movemask_pd(__m128d(r)));
  else
    return static_cast<unsigned>(kFloat ? _mm256_movemask_ps(__m256(r))
                                        : _mm256_movemask_pd(__m256d(r)));
}

// The sum of a 128-bit register's lanes, pairwise (SSE; NEON through intrin.hpp).
inline float lanes_sum(__m128 x) noexcept {
  x = _mm_add_ps(x, _mm_movehl_ps(x, x));
  return _mm_cvtss_f32(_mm_add_ss(x, _mm_shuffle_ps(x, x, 1)));
}
inline double lanes_sum(__m128d x) noexcept {
  return _mm_cvtsd_f64(_mm_add_sd(x, _mm_unpackhi_pd(x, x)));
}

// Whether the lanes of `valid` sum c to zero or more (the walks' direction codes: which way
// the packet's summed direction goes along an axis). Pairwise sums in registers, log2(W)
// dependent adds (a serial sum waits on W; sums through memory, on store forwarding).
template <class T, class Arch>
bool lanes_sum_up(const xsimd::batch_bool<T, Arch>& valid,
                  const xsimd::batch<T, Arch>& c) noexcept {
  using B = xsimd::batch<T, Arch>;
  using R = typename B::register_type;
  const R r = static_cast<R>(xsimd::select(valid, c, B(T(0))));
  constexpr bool kFloat = std::is_same_v<T, float>;
  constexpr std::size_t kBytes = sizeof(B);
  T sum;
  if constexpr (kBytes == 64) {  // AVX-512F's own reductions (halves, then quarters)
    if constexpr (kFloat)
      sum = _mm512_reduce_add_ps(__m512(r));
    else
      sum = _mm512_reduce_add_pd(__m512d(r));
  } else if constexpr (kBytes == 32) {
    if constexpr (kFloat)
      sum = lanes_sum(
          _mm_add_ps(_mm256_castps256_ps128(__m256(r)), _mm256_extractf128_ps(__m256(r), 1)));
    else
      sum = lanes_sum(
          _mm_add_pd(_mm256_castpd256_pd128(__m256d(r)), _mm256_extractf128_pd(__m256d(r), 1)));
  } else {
    if constexpr (kFloat)
      sum = lanes_sum(__m128(r));
    else
      sum = lanes_sum(__m128d(r));
  }
  return sum >= T(0);
}

// Of four zmm: the least (kMax: greatest) lane of x[p] in lanes 4p to 4p + 3 (a transposed
// reduction: two vectors' halves folded in one operation, then their quarters, then within
// quarters). AVX-512 code: used only there.
template <bool kMax>
__m512 fold_quarters(const __m512* x) noexcept {
  auto op = [](__m512 a, __m512 b) { return kMax ? _mm512_max_ps(a, b) : _mm512_min_ps(a, b); };
  const __m512 a = op(_mm512_shuffle_f32x4(x[0], x[1], _MM_SHUFFLE(1, 0, 1, 0)),
                      _mm512_shuffle_f32x4(x[0], x[1], _MM_SHUFFLE(3, 2, 3, 2)));
  const __m512 b = op(_mm512_shuffle_f32x4(x[2], x[3], _MM_SHUFFLE(1, 0, 1, 0)),
                      _mm512_shuffle_f32x4(x[2], x[3], _MM_SHUFFLE(3, 2, 3, 2)));
  __m512 u = op(_mm512_shuffle_f32x4(a, b, _MM_SHUFFLE(2, 0, 2, 0)),
                _mm512_shuffle_f32x4(a, b, _MM_SHUFFLE(3, 1, 3, 1)));
  u = op(u, _mm512_permute_ps(u, _MM_SHUFFLE(2, 3, 0, 1)));
  return op(u, _mm512_permute_ps(u, _MM_SHUFFLE(1, 0, 3, 2)));
}

}  // namespace lancer::packet
