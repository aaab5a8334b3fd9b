// Packet kernels for AVX2: explicit instantiations only. This file alone is built with
// -mavx2 -mfma (src/CMakeLists.txt). Exact mode never fuses (-ffp-contract=off); fast mode runs
// on xsimd's fma3<avx2>, the only AVX2 arch whose xsimd::fma is fused.
#include "lancer/packet/kernel.hpp"

namespace lancer::packet {

template const KernelTable<float>* table<xsimd::avx2, float, ExactMode>();
template const KernelTable<float>* table<xsimd::avx2, float, ProfiledMode>();
template const KernelTable<double>* table<xsimd::avx2, double, ExactMode>();
template const KernelTable<float>* table<xsimd::fma3<xsimd::avx2>, float, FastMode>();

}  // namespace lancer::packet
