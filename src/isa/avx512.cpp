// Packet kernels for AVX-512F: explicit instantiations only. This file alone is built with
// -mavx512f (src/CMakeLists.txt); the dispatcher calls it only where CPU and OS run AVX-512F.
#include "lancer/packet/kernel.hpp"

namespace lancer::packet {

template const KernelTable<float>* table<xsimd::avx512f, float, ExactMode>();
template const KernelTable<float>* table<xsimd::avx512f, float, ProfiledMode>();
template const KernelTable<double>* table<xsimd::avx512f, double, ExactMode>();
template const KernelTable<float>* table<xsimd::avx512f, float, FastMode>();

}  // namespace lancer::packet
