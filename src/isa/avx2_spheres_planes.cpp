// Exact packet kernels for avx2 built for spheres and planes alone (SpheresAndPlanes,
// packet/api.hpp): explicit instantiations only, with avx2.cpp's flags (src/CMakeLists.txt).
// A unit of their own, so that the build compiles them beside avx2.cpp's.
#include "lancer/packet/kernel.hpp"

namespace lancer::packet {

template const KernelTable<float>* table<xsimd::avx2, float, SpheresAndPlanes<ExactMode>>();
template const KernelTable<double>* table<xsimd::avx2, double, SpheresAndPlanes<ExactMode>>();

}  // namespace lancer::packet
