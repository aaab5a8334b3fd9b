// Packet kernels for SSE4.2: explicit instantiations only. This file alone is built with
// -msse4.2 (src/CMakeLists.txt); the dispatcher calls it only on CPUs that run SSE4.2.
// SSE4.2 has no FMA: the fast mode here gains only the approximate reciprocals.
#include "lancer/packet/kernel.hpp"

namespace lancer::packet {

template const KernelTable<float>* table<xsimd::sse4_2, float, ExactMode>();
template const KernelTable<float>* table<xsimd::sse4_2, float, ProfiledMode>();
template const KernelTable<double>* table<xsimd::sse4_2, double, ExactMode>();
template const KernelTable<float>* table<xsimd::sse4_2, float, FastMode>();

}  // namespace lancer::packet
