// The x86 intrinsics the kernels use beside xsimd, on every architecture. On x86-64 they are the
// compiler's own. Elsewhere (aarch64) SIMDe (Debian's libsimde-dev) implements the same
// functions and types over NEON, bit for bit as x86 defines them (its NaN and signed-zero rules
// included), so the kernels' one source serves both: the 128-bit paths run there as NEON, and the
// AVX and AVX-512 paths, never instantiated there, still name declared functions. Include only
// from code built for the batch's ISA.
#pragma once

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define LANCER_X86 1
#else
#define LANCER_X86 0
#if defined(__aarch64__) && !defined(LANCER_NEON64_IEEE)
#error "include lancer/packet/neon64_ieee.hpp first: xsimd 8.1's neon64 float division is not IEEE"
#endif
#define SIMDE_ENABLE_NATIVE_ALIASES
#include <simde/x86/avx512.h>
#include <simde/x86/fma.h>
// What SIMDe leaves unnamed: GCC's unaligned vector type and the AVX-512 mask types, and the
// AVX-512 functions it does not implement. The AVX-512 paths that name them are never
// instantiated here (declared only: a call would fail to link, never run wrongly).
using __m128i_u = simde__m128i;
using __mmask8 = simde__mmask8;
using __mmask16 = simde__mmask16;
simde__m512 _mm512_shuffle_f32x4(simde__m512, simde__m512, int);
simde__m512 _mm512_permute_ps(simde__m512, int);
float _mm512_cvtss_f32(simde__m512);
float _mm512_reduce_add_ps(simde__m512);
double _mm512_reduce_add_pd(simde__m512d);
simde__mmask16 _mm512_cmplt_epi32_mask(simde__m512i, simde__m512i);
simde__mmask16 _mm512_mask_cmp_ps_mask(simde__mmask16, simde__m512, simde__m512, int);
#endif

#include <xsimd/xsimd.hpp>

namespace lancer::packet {

// The 128-bit architecture every ISA of this machine's family includes: the one-ray paths' four
// float lanes (a node's four children, a leaf's spheres four at a time) run on it at every width.
#if LANCER_X86
using Arch4 = xsimd::sse4_2;
#else
using Arch4 = xsimd::neon64;
#endif

}  // namespace lancer::packet
