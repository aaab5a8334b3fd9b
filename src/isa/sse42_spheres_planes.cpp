// Exact packet kernels for sse42 built for spheres and planes alone (SpheresAndPlanes,
// packet/api.hpp): explicit instantiations only, with sse42.cpp's flags (src/CMakeLists.txt).
// A unit of their own, so that the build compiles them beside sse42.cpp's.
#include "lancer/packet/kernel.hpp"

namespace lancer::packet {

template const KernelTable<float>* table<xsimd::sse4_2, float, SpheresAndPlanes<ExactMode>>();
template const KernelTable<double>* table<xsimd::sse4_2, double, SpheresAndPlanes<ExactMode>>();

}  // namespace lancer::packet
