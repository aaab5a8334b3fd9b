// Correctly rounded float division and square root for xsimd 8.1's neon64 batches. xsimd 8.1
// gives neon64 float batches the kernels of 32-bit ARM NEON, which has no vector divide or
// square root: a reciprocal (square root) estimate refined by Newton steps, close but not IEEE.
// AArch64 has both (fdiv, fsqrt), and exact mode needs them: the reference divides and takes
// square roots in IEEE float. The overloads below take neon64 exactly, so they win over xsimd's
// neon ones (a derived-to-base match). xsimd's batch operators call kernel::div by qualified
// name, which sees only what is declared before them: include this before any other xsimd
// header (src/isa/neon64.cpp does; lane_traits.hpp refuses to build neon64 kernels without it).
#pragma once

#if defined(__aarch64__)
#include <arm_neon.h>

// What xsimd.hpp includes before its batch definitions.
#include <xsimd/arch/xsimd_scalar.hpp>
#include <xsimd/config/xsimd_arch.hpp>
#include <xsimd/config/xsimd_config.hpp>
#include <xsimd/memory/xsimd_aligned_allocator.hpp>
#include <xsimd/types/xsimd_utils.hpp>

namespace xsimd::kernel {
template <class A>
batch<float, A> div(const batch<float, A>& a, const batch<float, A>& b,
                    requires_arch<neon64>) noexcept;
template <class A>
batch<float, A> sqrt(const batch<float, A>& a, requires_arch<neon64>) noexcept;
}  // namespace xsimd::kernel

#include <xsimd/xsimd.hpp>

namespace xsimd::kernel {
template <class A>
batch<float, A> div(const batch<float, A>& a, const batch<float, A>& b,
                    requires_arch<neon64>) noexcept {
  return vdivq_f32(a, b);
}
template <class A>
batch<float, A> sqrt(const batch<float, A>& a, requires_arch<neon64>) noexcept {
  return vsqrtq_f32(a);
}
}  // namespace xsimd::kernel

#define LANCER_NEON64_IEEE 1
#endif
