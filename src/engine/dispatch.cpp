// The one dispatch point: which packet kernels this CPU and its OS run.
#include <cstdlib>
#include <string>
#include <xsimd/config/xsimd_arch.hpp>

#include "lancer/error.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/packet/one_ray_api.hpp"

namespace lancer::packet {

namespace {

#if defined(__x86_64__)
enum class Isa { sse4_2, avx2, avx512f };
#elif defined(__aarch64__)
enum class Isa { neon64 };
#else
#error "lancer's packet kernels are built for x86-64 and aarch64"
#endif

#if defined(__x86_64__)
// __builtin_cpu_supports reads CPUID and, for AVX and AVX-512, whether the OS saves their
// registers (XCR0), which xsimd 8's own detection does not check. Under valgrind, which has no
// AVX-512, CPUID reports none and we fall back to AVX2.
bool cpu_runs(Isa isa) {
  __builtin_cpu_init();
  switch (isa) {
    case Isa::sse4_2:
      return __builtin_cpu_supports("sse4.2");
    case Isa::avx2:
      return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    case Isa::avx512f:
      return __builtin_cpu_supports("avx512f");
  }
  return false;
}
int float_lanes(Isa isa) { return isa == Isa::sse4_2 ? 4 : isa == Isa::avx2 ? 8 : 16; }
#else
// Advanced SIMD is part of the AArch64 base architecture: every aarch64 CPU runs it.
bool cpu_runs(Isa) { return true; }
int float_lanes(Isa) { return 4; }
#endif

// LANCER_MAX_WIDTH caps the float width offered (1, 4, 8 or 16), to run a narrower ISA's path as
// a CPU without the wider one would. Parsed strictly: a cap that is not one of those is an error,
// never a silent "no packet widths".
int width_cap() {
  static const int cap = [] {
    const char* v = std::getenv("LANCER_MAX_WIDTH");
    if (!v) return 16;
    const std::string s(v);
    for (int w : {1, 4, 8, 16})
      if (s == std::to_string(w)) return w;
    return 0;
  }();
  if (cap == 0)
    throw InputError("LANCER_MAX_WIDTH: must be 1, 4, 8 or 16, not '" +
                     std::string(std::getenv("LANCER_MAX_WIDTH")) + "'");
  return cap;
}

bool allowed(Isa isa) { return float_lanes(isa) <= width_cap() && cpu_runs(isa); }

// Float lanes 4, 8, 16 and double lanes 2, 4, 8 map onto the same three x86 ISAs; on aarch64,
// float 4 and double 2 onto NEON's 128-bit registers.
bool isa_of(int lanes, bool dbl, Isa& isa) {
  const int base = dbl ? 2 : 4;
#if defined(__x86_64__)
  if (lanes == base) return isa = Isa::sse4_2, true;
  if (lanes == 2 * base) return isa = Isa::avx2, true;
  if (lanes == 4 * base) return isa = Isa::avx512f, true;
#else
  if (lanes == base) return isa = Isa::neon64, true;
#endif
  return false;
}

// The ISA a width of a precision runs on, if this CPU and OS run it. Every table<>() call below
// comes after this check: building a table runs that ISA's instructions.
bool runnable(int lanes, bool dbl, Isa& isa) { return isa_of(lanes, dbl, isa) && allowed(isa); }

// The table of one Real and Mode on the ISA `lanes` maps to, after the CPU check.
template <class Real, class Mode>
const KernelTable<Real>* table_for(int lanes) {
  Isa isa;
  if (!runnable(lanes, sizeof(Real) == 8, isa)) return nullptr;
#if defined(__x86_64__)
  switch (isa) {
    case Isa::sse4_2:
      return table<xsimd::sse4_2, Real, Mode>();
    case Isa::avx2:
      return table<xsimd::avx2, Real, Mode>();
    case Isa::avx512f:
      return table<xsimd::avx512f, Real, Mode>();
  }
  return nullptr;
#else
  return table<xsimd::neon64, Real, Mode>();
#endif
}

// The one-ray kernels on the widest ISA that runs, after the CPU check (AVX2 at least: a node's
// four double children take a ymm).
template <class Real>
const OneRayTable<Real>* one_ray_for() {
#if defined(__x86_64__)
  if (allowed(Isa::avx512f)) return one_ray_table<xsimd::avx512f, Real>();
  if (allowed(Isa::avx2)) return one_ray_table<xsimd::avx2, Real>();
#endif
  return nullptr;
}

}  // namespace

const OneRayTable<float>* one_ray_float() { return one_ray_for<float>(); }
const OneRayTable<double>* one_ray_double() { return one_ray_for<double>(); }

const KernelTable<float>* float_kernels(int width, Precision precision, bool shapes) {
  if (precision == Precision::exact)
    return shapes ? table_for<float, ExactMode>(width)
                  : table_for<float, SpheresAndPlanes<ExactMode>>(width);
  if (precision != Precision::fast) return nullptr;
  Isa isa;
  if (!runnable(width, false, isa)) return nullptr;
#if defined(__x86_64__)
  switch (isa) {  // fast AVX2 is fma3<avx2>: its fused operations need FMA
    case Isa::sse4_2:
      return table<xsimd::sse4_2, float, FastMode>();
    case Isa::avx2:
      return table<xsimd::fma3<xsimd::avx2>, float, FastMode>();
    case Isa::avx512f:
      return table<xsimd::avx512f, float, FastMode>();
  }
  return nullptr;
#else
  return table<xsimd::neon64, float, FastMode>();
#endif
}

const KernelTable<float>* profiled_kernels(int width) {
  return table_for<float, ProfiledMode>(width);
}

const KernelTable<double>* double_kernels(int width, bool shapes) {
  return shapes ? table_for<double, ExactMode>(width)
                : table_for<double, SpheresAndPlanes<ExactMode>>(width);
}

std::vector<int> supported_widths(Precision precision) {
  std::vector<int> w;
  if (precision == Precision::dbl) {
    for (int width : {8, 4, 2})
      if (double_kernels(width)) w.push_back(width);
    w.push_back(1);
    return w;
  }
  for (int width : {16, 8, 4})
    if (float_kernels(width, precision == Precision::fast ? Precision::fast : Precision::exact))
      w.push_back(width);
  if (precision != Precision::fast) w.push_back(1);  // fast mode runs on packets only
  return w;
}

std::string isa_name(int width, Precision precision) {
  if (width == 1) return "scalar";
#if defined(__aarch64__)
  // The x86 widths are named too: a request for one says what it would need.
  const int base = precision == Precision::dbl ? 2 : 4;
  if (width == base) return "neon64";
  if (width == 2 * base) return "avx2 (x86-64)";
  if (width == 4 * base) return "avx512f (x86-64)";
  return "none";
#else
  Isa isa;
  if (!isa_of(width, precision == Precision::dbl, isa)) return "none";
  if (isa == Isa::sse4_2) return "sse4.2";
  if (isa == Isa::avx2) return precision == Precision::fast ? "fma3<avx2>" : "avx2";
  return "avx512f";
#endif
}

}  // namespace lancer::packet
