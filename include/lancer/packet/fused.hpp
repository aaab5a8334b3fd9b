// Fused multiply-adds on xsimd batches, one rounding each. xsimd 8.1 fuses only for its
// fma3<...> architectures: for avx512f its fma, fms and fnma are a multiplication then an
// addition (two roundings, and two instructions under -ffp-contract=off), so AVX-512F gets its
// own intrinsics here. SSE4.2 has no FMA instruction: there the unfused pair is what it has.
// On aarch64 the 128-bit x86 names come from SIMDe (intrin.hpp).
// Include only from code built for the batch's ISA (packet/kernel.hpp, src/isa/).
#pragma once

#include <cstddef>
#include <type_traits>
#include <xsimd/xsimd.hpp>

#include "lancer/packet/intrin.hpp"

namespace lancer::packet {

template <class Arch>
inline constexpr bool kAvx512 = std::is_same_v<Arch, xsimd::avx512f>;
// The AVX2 path runs only where the CPU has FMA too (src/engine/dispatch.cpp) and is built with
// -mfma; its exact mode keeps multiplications and additions apart in every pixel formula, and only
// the traversal's slab test (a conservative cull, not a pixel value) uses fmsub on it.
template <class Arch>
inline constexpr bool kAvx2 = std::is_same_v<Arch, xsimd::avx2>;

template <class Arch>
struct IsFma3 : std::false_type {};
template <class Arch>
struct IsFma3<xsimd::fma3<Arch>> : std::true_type {};
// NEON's fma and fms (xsimd: vfmaq) are fused: aarch64 has no unfused multiply-add. Exact mode
// uses them only where AVX2 does, in the traversal's slab test.
template <class Arch>
inline constexpr bool kNeon64 = std::is_same_v<Arch, xsimd::neon64>;
// Whether fmsub below rounds once on this arch (interval bounds must round as the lanes do).
template <class Arch>
inline constexpr bool kFusedFmsub =
    kAvx512<Arch> || kAvx2<Arch> || IsFma3<Arch>::value || kNeon64<Arch>;

// a * b + c
template <class T, class Arch>
xsimd::batch<T, Arch> fmadd(const xsimd::batch<T, Arch>& a, const xsimd::batch<T, Arch>& b,
                            const xsimd::batch<T, Arch>& c) noexcept {
  if constexpr (kAvx512<Arch> && std::is_same_v<T, float>)
    return _mm512_fmadd_ps(a, b, c);
  else if constexpr (kAvx512<Arch>)
    return _mm512_fmadd_pd(a, b, c);
  else
    return xsimd::fma(a, b, c);
}

// a * b - c. Written out rather than as fmadd(a, b, -c), which gives the same bits: GCC does not
// always fold that negation into vfmsub, and fast mode's full render lost 5% at width 16.
template <class T, class Arch>
xsimd::batch<T, Arch> fmsub(const xsimd::batch<T, Arch>& a, const xsimd::batch<T, Arch>& b,
                            const xsimd::batch<T, Arch>& c) noexcept {
  if constexpr (kAvx512<Arch> && std::is_same_v<T, float>)
    return _mm512_fmsub_ps(a, b, c);
  else if constexpr (kAvx512<Arch>)
    return _mm512_fmsub_pd(a, b, c);
  else if constexpr (kAvx2<Arch> && std::is_same_v<T, float>)
    return _mm256_fmsub_ps(a, b, c);
  else if constexpr (kAvx2<Arch>)
    return _mm256_fmsub_pd(a, b, c);
  else
    return xsimd::fms(a, b, c);
}

// c - a * b (likewise not fmadd(-a, b, c)).
template <class T, class Arch>
xsimd::batch<T, Arch> fnmadd(const xsimd::batch<T, Arch>& a, const xsimd::batch<T, Arch>& b,
                             const xsimd::batch<T, Arch>& c) noexcept {
  if constexpr (kAvx512<Arch> && std::is_same_v<T, float>)
    return _mm512_fnmadd_ps(a, b, c);
  else if constexpr (kAvx512<Arch>)
    return _mm512_fnmadd_pd(a, b, c);
  else
    return xsimd::fnma(a, b, c);
}

// a * b - c for a box test's slab on a register of 128 or 256 bits of this unit's family, by
// how its ISA can: one rounding with FMA3 (-mfma, the AVX2 units), in the low lanes of a zmm
// with AVX-512F alone (which has no narrower FMA), or NEON's own; two roundings on SSE4.2.
// Callers bound either (the shapes' walks' margins: prim/shapes_walk.hpp).
template <class T, class A>
xsimd::batch<T, A> slab_fmsub(const xsimd::batch<T, A>& a, const xsimd::batch<T, A>& b,
                              const xsimd::batch<T, A>& c) noexcept {
  [[maybe_unused]] constexpr bool kFloat = std::is_same_v<T, float>;
  [[maybe_unused]] constexpr std::size_t kBytes = sizeof(xsimd::batch<T, A>);
#if defined(__FMA__)
  if constexpr (kBytes == 32 && kFloat)
    return _mm256_fmsub_ps(a, b, c);
  else if constexpr (kBytes == 32)
    return _mm256_fmsub_pd(a, b, c);
  else if constexpr (kFloat)
    return _mm_fmsub_ps(a, b, c);
  else
    return _mm_fmsub_pd(a, b, c);
#elif defined(__AVX512F__)
  if constexpr (kBytes == 32 && kFloat)
    return _mm512_castps512_ps256(_mm512_fmsub_ps(
        _mm512_zextps256_ps512(a), _mm512_zextps256_ps512(b), _mm512_zextps256_ps512(c)));
  else if constexpr (kBytes == 32)
    return _mm512_castpd512_pd256(_mm512_fmsub_pd(
        _mm512_zextpd256_pd512(a), _mm512_zextpd256_pd512(b), _mm512_zextpd256_pd512(c)));
  else if constexpr (kFloat)
    return _mm512_castps512_ps128(_mm512_fmsub_ps(
        _mm512_zextps128_ps512(a), _mm512_zextps128_ps512(b), _mm512_zextps128_ps512(c)));
  else
    return _mm512_castpd512_pd128(_mm512_fmsub_pd(
        _mm512_zextpd128_pd512(a), _mm512_zextpd128_pd512(b), _mm512_zextpd128_pd512(c)));
#elif defined(__aarch64__)
  if constexpr (kFloat)
    return vfmaq_f32(vnegq_f32(c), a, b);
  else
    return vfmaq_f64(vnegq_f64(c), a, b);
#else
  return a * b - c;
#endif
}

}  // namespace lancer::packet
