// The one-ray kernels (packet/one_ray.hpp) for AVX-512F: explicit instantiations only. This file
// alone is built with -mavx512f (src/CMakeLists.txt); the dispatcher calls it only where CPU and
// OS run AVX-512F.
#include "lancer/packet/one_ray.hpp"

namespace lancer::packet {

template const OneRayTable<float>* one_ray_table<xsimd::avx512f, float>();
template const OneRayTable<double>* one_ray_table<xsimd::avx512f, double>();

}  // namespace lancer::packet
