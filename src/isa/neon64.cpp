// Packet kernels for aarch64's Advanced SIMD (NEON, 128-bit: 4 floats, 2 doubles): explicit
// instantiations only, from the same kernel source as x86's. NEON is part of the base
// architecture: no flags, and the dispatcher offers it on every aarch64 CPU. Its fma is fused,
// so fast mode gains fused multiply-adds here as on AVX2.
// First: xsimd 8.1 would otherwise divide and take square roots of floats approximately.
#include "lancer/packet/neon64_ieee.hpp"
// Then the kernels.
#include "lancer/packet/kernel.hpp"

namespace lancer::packet {

template const KernelTable<float>* table<xsimd::neon64, float, ExactMode>();
template const KernelTable<float>* table<xsimd::neon64, float, ProfiledMode>();
template const KernelTable<double>* table<xsimd::neon64, double, ExactMode>();
template const KernelTable<float>* table<xsimd::neon64, float, FastMode>();

}  // namespace lancer::packet
