// Exact packet kernels for avx512 built for spheres and planes alone (SpheresAndPlanes,
// packet/api.hpp): explicit instantiations only, with avx512.cpp's flags (src/CMakeLists.txt).
// A unit of their own, so that the build compiles them beside avx512.cpp's.
#include "lancer/packet/kernel.hpp"

namespace lancer::packet {

template const KernelTable<float>* table<xsimd::avx512f, float, SpheresAndPlanes<ExactMode>>();
template const KernelTable<double>* table<xsimd::avx512f, double, SpheresAndPlanes<ExactMode>>();

}  // namespace lancer::packet
