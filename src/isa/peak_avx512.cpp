// Peak float arithmetic for AVX-512F (16 lanes), built with -mavx512f: one vfmadd on zmm per
// chain per round, and the mul+add variant. Explicit instantiations only; see
// include/lancer/peak.hpp.
#include "lancer/peak.hpp"
#include "peak_chains.hpp"

namespace lancer::peak_kernels {

template double chains<xsimd::avx512f, true, kPeakChainsAvx512>(long);
template double chains<xsimd::avx512f, false, kPeakChainsAvx512>(long);

}  // namespace lancer::peak_kernels
