// The peak-arithmetic kernels of src/isa/peak_*.cpp (and the scalar one of src/peak.cpp), declared
// without SIMD types so that baseline code can call them once the CPU is known to run them.
// Each runs `iterations` rounds of independent chains x = x * a + b and returns the flops done
// (2 per lane per chain per round: one FMA, or one mul and one add). See include/lancer/peak.hpp.
#pragma once

namespace lancer::peak_kernels {

double scalar_muladd(long iterations);  // src/peak.cpp, baseline x86-64
double sse42_muladd(long iterations);   // src/isa/peak_sse42.cpp
double avx2_fma(long iterations);       // src/isa/peak_avx2.cpp
double avx2_muladd(long iterations);
double avx512_fma(long iterations);  // src/isa/peak_avx512.cpp
double avx512_muladd(long iterations);

// Where each kernel leaves its chains' sum, so that the compiler must compute them.
extern volatile float sink;

}  // namespace lancer::peak_kernels
