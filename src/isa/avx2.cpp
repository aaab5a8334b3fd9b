// Packet kernels for AVX2 (with FMA available but never contracted: -ffp-contract=off): explicit instantiations only. This file alone is built with
// this ISA's flags (see src/CMakeLists.txt); the dispatcher decides at run time whether to call it.
#include "lancer/packet/kernel.hpp"

namespace lancer::packet {

template void render_rows<xsimd::avx2>(xsimd::avx2, const PreparedScene<float>&, Image&, int,
                                        int, RayCounts&);
template void primary_rows<xsimd::avx2>(xsimd::avx2, const PreparedScene<float>&, float*, int,
                                         int, RayCounts&);
template void closest_hit_packet<xsimd::avx2>(xsimd::avx2, const PreparedScene<float>&,
                                               const bool*, const float*, float*, float*, bool*);

}  // namespace lancer::packet
