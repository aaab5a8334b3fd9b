// The machine's limit, and how close lancer's intersection tests come to it.
//
// 1. Peak single-thread float arithmetic per ISA, measured: independent chains x = x * a + b,
//    enough of them (kPeakChains) to cover the latency times the throughput of the FP units of
//    current x86 cores (4-5 cycles x 2-4 ops per cycle), each chain one register:
//      width 1:  scalar mulss + addss (the baseline ISA the reference is built for);
//      width 4:  SSE4.2 mulps + addps: SSE has no FMA, so a mul+add pair counts 2 flops;
//      width 8:  AVX2 vfmadd (FMA3): one FMA counts 2 flops;
//      width 16: AVX-512F vfmadd on zmm: one FMA counts 2 flops.
//    Each kernel lives in its own translation unit built with that ISA's flags
//    (src/isa/peak_*.cpp) and runs only where packet::kernels_for(width) says the CPU runs it.
//    lancer itself is built with -ffp-contract=off and so never issues an FMA: its own ceiling
//    at widths 8 and 16 is the mul+add rate, which peak_muladd_gflops() measures the same way.
//    (Cores with separate FADD pipes, e.g. AMD Zen, reach the same flops either way; cores that
//    add and multiply on the FMA ports, e.g. Intel's, reach half with mul+add.)
//
// 2. Flops of lancer's intersection tests, counted from packet/kernel.hpp closest_hit() and
//    formulas.hpp as written. What counts as a flop: each add, sub, mul, div and sqrt is one
//    flop (a div or sqrt costs far more time than a mul, but counts one, as is the custom);
//    a negation (-x, a sign-bit xor) is not a flop; compares and selects (blends) are counted
//    apart, not as flops; mask logic (&, ~, any) and broadcasts of per-object constants are not
//    counted at all.
//
//    Sphere, per ray and sphere. The common path, always run (for most rays it is all there is,
//    because the discriminant is negative):
//      f = o - C                    3 sub   (not on the pinhole camera path: precomputed)
//      b = dot(f, d)                3 mul + 2 add
//      perp = f - d * b             3 mul + 3 sub
//      dot(perp, perp)              3 mul + 2 add
//      disc = r^2 - dot             1 sub
//      disc >= 0                    1 compare
//    => 17 flops from the eye (pinhole camera rays in the packets: f per sphere comes from the
//       prepared EyeSphere tables), 20 flops in general (the reference, orthographic cameras,
//       shadow and reflected rays); 1 compare.
//    The hit path, run when disc >= 0 (for a packet: when any of its lanes has disc >= 0):
//      c = dot(f, f) - r^2          3 mul + 2 add + 1 sub   (not from the eye: precomputed)
//      s = sqrt(disc)               1 sqrt
//      q = b < 0 ? s - b : -(b + s) 1 sub + 1 add, 1 compare, 1 select (the negation is free)
//      t0 = c / q                   1 div
//      near, far = t0 < q ? ...     1 compare (shared by both selects), 2 selects
//      t = near > eps ? near : far  1 compare, 1 select
//      t > eps, t < best_t          2 compares
//      best_t, best_id updates      2 selects
//    => 4 flops from the eye, 10 in general; 5 compares, 6 selects.
//
//    Plane, per ray and plane, no early exit:
//      denom = dot(d, N)            3 mul + 2 add
//      dot(Q - o, N)                3 sub + 3 mul + 2 add
//      t = ... / denom              1 div
//      denom != 0, t > eps, t < best_t   3 compares;  best_t, best_id updates  2 selects
//    => 14 flops; 3 compares, 2 selects.
//
//    Not counted in the intersection flops: making the camera ray (kCameraRayFlops), the
//    running sum of t per pixel in primary mode (1 add per ray), the final "t < infinity" test
//    (1 compare per ray), loads, gathers and loop control.
#pragma once

#include <string>
#include <vector>

#include "lancer/scene.hpp"

namespace lancer {

// Independent accumulator chains of each peak kernel (registers: 12 of the 16 xmm/ymm; 16 of the
// 32 zmm, since AVX-512 cores have the longest latency x throughput products).
inline constexpr int kPeakChains = 12;
inline constexpr int kPeakChainsAvx512 = 16;

// Sphere: common path (discriminant) and the extra flops of the hit path.
inline constexpr int kSphereDiscFlopsFromEye = 17;
inline constexpr int kSphereDiscFlops = 20;
inline constexpr int kSphereHitFlopsFromEye = 4;
inline constexpr int kSphereHitFlops = 10;
inline constexpr int kSphereDiscCompares = 1;
inline constexpr int kSphereHitCompares = 5;
inline constexpr int kSphereHitSelects = 6;
// Plane: one path.
inline constexpr int kPlaneFlops = 14;
inline constexpr int kPlaneCompares = 3;
inline constexpr int kPlaneSelects = 2;
// A pinhole camera ray from the screen tables: x u + y v (6 mul + 3 add), minus distance * w
// (3 mul + 3 sub), normalised (dot 3 mul + 2 add, 1 sqrt, 3 div). Orthographic: x u + y v and
// position + that (9 + 3). The reference (width 1) also computes screen x and y per ray
// (2 x (add, mul, div, add/sub) = 8 more). Reported for reference; not in the gflops.
inline constexpr int kCameraRayFlopsPinhole = 24;
inline constexpr int kCameraRayFlopsOrthographic = 12;

// The peak kernel of `width` (fma: FMA at widths 8 and 16; mul+add otherwise, and always at 1
// and 4): kernel(iterations) runs that many iterations of every chain and returns the flops
// done. nullptr if this CPU does not run that ISA.
using PeakKernel = double (*)(long iterations);
// Iterations per timed call: about half a millisecond at every width.
inline constexpr long kPeakBatch = 1L << 18;
PeakKernel peak_kernel(int width, bool fma);

// Single-thread peak of the float ISA of `width` (1 scalar, 4 SSE4.2 mul+add, 8 AVX2 FMA,
// 16 AVX-512F FMA), in GFLOP/s, measured over about `seconds`. 0 if this CPU does not run it.
double peak_gflops(int width, double seconds);
// The same with separate mul and add instructions at widths 8 and 16 (lancer's own ceiling, as
// it never contracts to FMA); equal to peak_gflops at widths 1 and 4.
double peak_muladd_gflops(int width, double seconds);

// Flops per camera ray of lancer's primary mode at `width` on `scene`, from the counts above:
// spheres x (common + h x hit) + planes x kPlaneFlops, h found by running the discriminant of
// every camera ray against every sphere (in float, as lancer does; not timed).
//  - per_ray: h = the fraction of (ray, sphere) pairs with disc >= 0: the work the algorithm
//    needs, whatever the width;
//  - per_lane: what the SIMD lanes execute, per ray: a packet runs the hit path for all its
//    lanes when any has disc >= 0, and a partial packet at a row's end runs all its lanes.
// Pinhole cameras at width > 1 use the from-eye counts; width 1 and orthographic cameras the
// general ones.
struct PrimaryFlops {
  double per_ray = 0;
  double per_lane = 0;
  double sphere_hit_fraction = 0;  // h of per_ray
};
PrimaryFlops primary_flops(const Scene& scene, int width);

}  // namespace lancer
