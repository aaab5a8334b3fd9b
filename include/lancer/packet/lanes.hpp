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
