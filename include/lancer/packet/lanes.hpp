// A batch mask as one bit per lane (xsimd 8.1 has no mask()), for kernel.hpp and traverse.hpp.
// Include only from code built for the batch's ISA.
#pragma once

#include <immintrin.h>  // every ISA's register types

#include <type_traits>
#include <xsimd/xsimd.hpp>

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

}  // namespace lancer::packet
