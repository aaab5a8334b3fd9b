// The peak-arithmetic kernels of src/isa/peak_*.cpp (and the scalar one of src/tools/peak.cpp),
// declared without SIMD types so that baseline code can call them once the CPU is known to run
// them. Each runs `iterations` rounds of independent chains x = x * a + b and returns the flops
// done (2 per lane per chain per round: one FMA, or one mul and one add). See
// include/lancer/peak.hpp.
#pragma once

namespace lancer::peak_kernels {

double scalar_muladd(long iterations);  // src/tools/peak.cpp, baseline x86-64

// N independent chains on batch<float, Arch>: xsimd::fma (one vfmadd, for fma3<avx2> and
// avx512f) or a mul then an add (never fused: -ffp-contract=off). Defined in
// peak_chains.hpp, instantiated only in the per-ISA src/isa/peak_*.cpp.
template <class Arch, bool kFma, int N>
double chains(long iterations);

// Where each kernel leaves its chains' sum, so that the compiler must compute them.
extern volatile float sink;

}  // namespace lancer::peak_kernels
