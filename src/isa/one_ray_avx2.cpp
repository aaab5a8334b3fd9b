// The one-ray kernels (packet/one_ray.hpp) for AVX2: explicit instantiations only. This file
// alone is built with -mavx2 -mfma (src/CMakeLists.txt); exact arithmetic never fuses
// (-ffp-contract=off).
#include "lancer/packet/one_ray.hpp"

namespace lancer::packet {

template const OneRayTable<float>* one_ray_table<xsimd::avx2, float>();
template const OneRayTable<double>* one_ray_table<xsimd::avx2, double>();

}  // namespace lancer::packet
