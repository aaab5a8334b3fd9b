// Fused multiply-adds on xsimd batches, one rounding each. xsimd 8.1 fuses only for its
// fma3<...> architectures: for avx512f its fma, fms and fnma are a multiplication then an
// addition (two roundings, and two instructions under -ffp-contract=off), so AVX-512F gets its
// own intrinsics here. SSE4.2 has no FMA instruction: there the unfused pair is what it has.
// On aarch64 the 128-bit x86 names come from SIMDe (intrin.hpp).
// Include only from code built for the batch's ISA (packet/kernel.hpp, src/isa/).
#pragma once

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

}  // namespace lancer::packet
