// Packet kernels for AVX-512F: explicit instantiations only. This file alone is built with
// this ISA's flags (see src/CMakeLists.txt); the dispatcher decides at run time whether to call it.
#include "lancer/packet/kernel.hpp"

namespace lancer::packet {

template void render_rows<xsimd::avx512f>(xsimd::avx512f, const PreparedScene<float>&, Image&, int,
                                        int, RayCounts&);
template void primary_rows<xsimd::avx512f>(xsimd::avx512f, const PreparedScene<float>&, float*, int,
                                         int, RayCounts&);
template void closest_hit_packet<xsimd::avx512f>(xsimd::avx512f, const PreparedScene<float>&,
                                               const bool*, const float*, float*, float*, bool*);

}  // namespace lancer::packet
