// The machine's peak (dispatching to src/isa/peak_*.cpp) and the flop counts of lancer's
// primary rays. See include/lancer/peak.hpp for what is counted and how.
#include "lancer/peak.hpp"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <xsimd/config/xsimd_arch.hpp>

#include "../isa/peak_kernels.hpp"
#include "lancer/formulas.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/prepared.hpp"

namespace lancer {

namespace peak_kernels {

volatile float sink = 0;

#if defined(__x86_64__)
// Scalar mulss + addss. The _ss intrinsics keep the compiler from packing the chains into
// vectors (which it could do with plain float code), so this is the width-1 rate.
double scalar_muladd(long iterations) {
  constexpr int N = kPeakChains;
  const __m128 a = _mm_set_ss(0.999f), b = _mm_set_ss(1e-3f);
  __m128 acc[N];
#pragma GCC unroll 16
  for (int k = 0; k < N; ++k) acc[k] = _mm_set_ss(1.0f + 0.01f * k);
  for (long i = 0; i < iterations; ++i) {
#pragma GCC unroll 16
    for (int k = 0; k < N; ++k) acc[k] = _mm_add_ss(_mm_mul_ss(acc[k], a), b);
  }
  __m128 sum = acc[0];
  for (int k = 1; k < N; ++k) sum = _mm_add_ss(sum, acc[k]);
  sink = _mm_cvtss_f32(sum);
  return 2.0 * N * double(iterations);
}
#else
// Scalar fmul + fadd: the empty asm keeps each chain in its own register, so that the compiler
// cannot pack the chains into vectors (nor fuse them: -ffp-contract=off).
double scalar_muladd(long iterations) {
  constexpr int N = kPeakChains;
  const float a = 0.999f, b = 1e-3f;
  float acc[N];
#pragma GCC unroll 16
  for (int k = 0; k < N; ++k) acc[k] = 1.0f + 0.01f * k;
  for (long i = 0; i < iterations; ++i) {
#pragma GCC unroll 16
    for (int k = 0; k < N; ++k) {
      acc[k] = acc[k] * a + b;
      asm volatile("" : "+w"(acc[k]));
    }
  }
  float sum = acc[0];
  for (int k = 1; k < N; ++k) sum += acc[k];
  sink = sum;
  return 2.0 * N * double(iterations);
}
#endif

}  // namespace peak_kernels

namespace {

using Clock = std::chrono::steady_clock;

// GFLOP/s of `kernel` over about `seconds`, after a short warm-up (wide units may be powered
// up, and the clock raised, only once they are in use).
double measure(PeakKernel kernel, double seconds) {
  kernel(kPeakBatch);
  double flops = 0, elapsed = 0;
  const auto start = Clock::now();
  do {
    flops += kernel(kPeakBatch);
    elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  } while (elapsed < seconds);
  return flops / elapsed * 1e-9;
}

bool runs(int width) { return width == 1 || packet::kernels_for(width) != nullptr; }

}  // namespace

PeakKernel peak_kernel(int width, bool fma) {
  if (!runs(width)) return nullptr;
  switch (width) {
    case 1:
      return peak_kernels::scalar_muladd;
#if defined(__aarch64__)
    case 4:
      return fma ? peak_kernels::chains<xsimd::neon64, true, kPeakChains>
                 : peak_kernels::chains<xsimd::neon64, false, kPeakChains>;
#else
    case 4:
      return peak_kernels::chains<xsimd::sse4_2, false, kPeakChains>;
    case 8:
      return fma ? peak_kernels::chains<xsimd::fma3<xsimd::avx2>, true, kPeakChains>
                 : peak_kernels::chains<xsimd::avx2, false, kPeakChains>;
    case 16:
      return fma ? peak_kernels::chains<xsimd::avx512f, true, kPeakChainsAvx512>
                 : peak_kernels::chains<xsimd::avx512f, false, kPeakChainsAvx512>;
#endif
    default:
      return nullptr;
  }
}

double peak_gflops(int width, double seconds) {
  const PeakKernel k = peak_kernel(width, true);
  return k ? measure(k, seconds) : 0;
}

double peak_muladd_gflops(int width, double seconds) {
  const PeakKernel k = peak_kernel(width, false);
  return k ? measure(k, seconds) : 0;
}

PrimaryFlops primary_flops(const Scene& scene, int width) {
  const PreparedScene<float> s = prepare<float>(scene);
  const PreparedCamera<float>& cam = s.camera;
  const bool from_eye = width > 1 && !cam.orthographic;
  const double disc = from_eye ? kSphereDiscFlopsFromEye : kSphereDiscFlops;
  const double hit = from_eye ? kSphereHitFlopsFromEye : kSphereHitFlops;
  const int lanes = std::max(1, width);

  // Every camera ray against every sphere: which pairs take the hit path, per ray and per
  // packet (columns i0 .. i0+width-1 of a row, as the kernels group them).
  double rays = 0, hit_pairs = 0, lane_slots = 0, packet_hit_lanes = 0;
  std::vector<char> lane_hits;
  for (int b = 0; b < cam.samples; ++b)
    for (int j = 0; j < cam.ny; ++j)
      for (int a = 0; a < cam.samples; ++a)
        for (int i0 = 0; i0 < cam.nx; i0 += lanes) {
          const int n = std::min(lanes, cam.nx - i0);
          rays += n;
          lane_slots += lanes;
          for (int i = 0; i < s.num_spheres; ++i) {
            bool any = false;
            for (int k = 0; k < n; ++k) {
              Vec3<float> o, d;
              camera_ray(cam, cam.screen_x[std::size_t(a) * cam.nx + i0 + k],
                         cam.screen_y[std::size_t(b) * cam.ny + j], o, d);
              const Vec3<float> f =
                  o - Vec3<float>{s.spheres.cx[i], s.spheres.cy[i], s.spheres.cz[i]};
              const bool h = sphere_disc(f, d, s.spheres.r2[i]).disc >= 0.0f;
              hit_pairs += h;
              any = any || h;
            }
            if (any) packet_hit_lanes += lanes;
          }
        }
  PrimaryFlops out;
  if (rays == 0) return out;
  const double spheres = s.num_spheres, planes = s.num_planes;
  out.sphere_hit_fraction = spheres > 0 ? hit_pairs / (rays * spheres) : 0;
  out.per_ray = spheres * disc + hit * hit_pairs / rays + planes * kPlaneFlops;
  out.per_lane =
      (lane_slots * (spheres * disc + planes * kPlaneFlops) + packet_hit_lanes * hit) / rays;
  return out;
}

}  // namespace lancer
