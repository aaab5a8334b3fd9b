// Exact packet kernels for neon64 built for spheres and planes alone (SpheresAndPlanes,
// packet/api.hpp): explicit instantiations only, with neon64.cpp's flags (src/CMakeLists.txt).
// A unit of their own, so that the build compiles them beside neon64.cpp's.
// First: xsimd 8.1 would otherwise divide and take square roots of floats approximately.
#include "lancer/packet/neon64_ieee.hpp"
// Then the kernels.
#include "lancer/packet/kernel.hpp"

namespace lancer::packet {

template const KernelTable<float>* table<xsimd::neon64, float, SpheresAndPlanes<ExactMode>>();
template const KernelTable<double>* table<xsimd::neon64, double, SpheresAndPlanes<ExactMode>>();

}  // namespace lancer::packet
