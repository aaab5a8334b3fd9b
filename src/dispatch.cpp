// The one dispatch point: which packet widths this CPU and its OS run, and their kernels.
#include <cstdlib>
#include <cstring>
#include <xsimd/config/xsimd_arch.hpp>

#include "lancer/packet/api.hpp"

namespace lancer::packet {

namespace {

// __builtin_cpu_supports reads CPUID and, for AVX and AVX-512, whether the OS saves their
// registers (XCR0), which xsimd 8's own detection does not check. Under valgrind, which has no
// AVX-512, CPUID reports none and we fall back to AVX2.
bool cpu_runs(int width) {
  __builtin_cpu_init();
  switch (width) {
    case 4:
      return __builtin_cpu_supports("sse4.2");
    case 8:
      return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    case 16:
      return __builtin_cpu_supports("avx512f");
    default:
      return false;
  }
}

template <class Arch>
Kernels make(int width) {
  return Kernels{width, Arch::name(),
                 [](const PreparedScene<float>& s, Image& im, int r0, int r1, RayCounts& c) {
                   render_rows(Arch{}, s, im, r0, r1, c);
                 },
                 [](const PreparedScene<float>& s, float* t, int r0, int r1, RayCounts& c) {
                   primary_rows(Arch{}, s, t, r0, r1, c);
                 },
                 [](const PreparedScene<float>& s, const bool* v, const float* rays, float* t,
                    float* id, bool* hit) { closest_hit_packet(Arch{}, s, v, rays, t, id, hit); }};
}

// LANCER_MAX_WIDTH caps the widths offered, to try a narrower ISA's path as a CPU without the
// wider one would run it.
int max_width_from_env() {
  const char* v = std::getenv("LANCER_MAX_WIDTH");
  if (!v || !*v) return 16;
  return std::atoi(v);
}

}  // namespace

const Kernels* kernels_for(int width) {
  static const Kernels k4 = make<xsimd::sse4_2>(4);
  static const Kernels k8 = make<xsimd::avx2>(8);
  static const Kernels k16 = make<xsimd::avx512f>(16);
  static const int cap = max_width_from_env();
  if (width > cap || !cpu_runs(width)) return nullptr;
  switch (width) {
    case 4:
      return &k4;
    case 8:
      return &k8;
    case 16:
      return &k16;
    default:
      return nullptr;
  }
}

std::vector<int> supported_widths() {
  std::vector<int> w;
  for (int width : {16, 8, 4})
    if (kernels_for(width)) w.push_back(width);
  w.push_back(1);
  return w;
}

std::string isa_name(int width) {
  if (width == 1) return "scalar";
  const Kernels* k = kernels_for(width);
  if (k) return k->isa;
  return width == 4 ? "sse4.2" : width == 8 ? "avx2" : width == 16 ? "avx512f" : "unknown";
}

}  // namespace lancer::packet
