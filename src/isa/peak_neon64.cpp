// Peak float arithmetic for aarch64's NEON (4 lanes): fmla (fused, one instruction counting 2
// flops) or fmul then fadd. Explicit instantiations only; see include/lancer/peak.hpp.
#include "lancer/packet/neon64_ieee.hpp"  // first, as in every neon64 unit
#include "lancer/peak.hpp"
#include "peak_chains.hpp"

namespace lancer::peak_kernels {

template double chains<xsimd::neon64, false, kPeakChains>(long);
template double chains<xsimd::neon64, true, kPeakChains>(long);

}  // namespace lancer::peak_kernels
