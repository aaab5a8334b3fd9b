// Peak float arithmetic for SSE4.2 (4 lanes), built with -msse4.2: no FMA exists, so a mulps and
// an addps per chain per round. Explicit instantiations only; see include/lancer/peak.hpp.
#include "lancer/peak.hpp"
#include "peak_chains.hpp"

namespace lancer::peak_kernels {

template double chains<xsimd::sse4_2, false, kPeakChains>(long);

}  // namespace lancer::peak_kernels
