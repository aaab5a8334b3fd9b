// Peak float arithmetic for AVX2 (8 lanes), built with -mavx2 -mfma: fused on xsimd's fma3<avx2>,
// and the mul+add variant lancer's -ffp-contract=off code is limited to. Explicit
// instantiations only; see include/lancer/peak.hpp.
#include "lancer/peak.hpp"
#include "peak_chains.hpp"

namespace lancer::peak_kernels {

template double chains<xsimd::fma3<xsimd::avx2>, true, kPeakChains>(long);
template double chains<xsimd::avx2, false, kPeakChains>(long);

}  // namespace lancer::peak_kernels
