// The Embree peer's user spheres: the callbacks Embree calls with packets of N rays (1, 4, 8 or
// 16, as the tracing call asks) on a sphere its BVH met. One loop of selects without a branch
// over Embree's SoA fields, so the compiler vectorises it, compiled for each x86 level and
// picked by the CPU at load time: the peer's callback as its user would build it for the
// machine. Included by peer_embree_impl.hpp alone, inside LANCER_HAVE_EMBREE.
#pragma once

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "lancer/prepared.hpp"
#include "peer_embree_shapes.hpp"

namespace lancer::peer {

// Lanes [i0, i0 + n) of a packet of N rays (Embree's SoA layout: each field an array of N)
// against sphere k: the nearest root of |o + t d - c| = r within (tnear, tfar), Embree's own
// formula family (b^2 - a (|oc|^2 - r^2)), not lancer's: the peer's arithmetic stays the
// peer's. Out: t, and hit -1 where a valid lane hits, else 0.
LANCER_PEER_CLONES
inline void sphere_lanes(const PreparedScene<float>& s, unsigned k, const float* ray, unsigned N,
                         unsigned i0, unsigned n, const int* valid, float* __restrict t,
                         int* __restrict hit) {
  const float* __restrict ox = ray + 0 * N + i0;
  const float* __restrict oy = ray + 1 * N + i0;
  const float* __restrict oz = ray + 2 * N + i0;
  const float* __restrict tn = ray + 3 * N + i0;
  const float* __restrict dx = ray + 4 * N + i0;
  const float* __restrict dy = ray + 5 * N + i0;
  const float* __restrict dz = ray + 6 * N + i0;
  const float* __restrict tf = ray + 8 * N + i0;
  const float cx = s.spheres.cx[k], cy = s.spheres.cy[k], cz = s.spheres.cz[k];
  const float r = s.spheres.r[k];
  for (unsigned i = 0; i < n; ++i) {
    const float px = ox[i] - cx, py = oy[i] - cy, pz = oz[i] - cz;
    const float a = dx[i] * dx[i] + dy[i] * dy[i] + dz[i] * dz[i];
    const float b = px * dx[i] + py * dy[i] + pz * dz[i];
    const float c = px * px + py * py + pz * pz - r * r;
    const float disc = b * b - a * c;
    const float q = std::sqrt(disc > 0.0f ? disc : 0.0f);
    const float t0 = (-b - q) / a, t1 = (-b + q) / a;
    const float lo = tn[i], hi = tf[i];
    const float best = t0 > lo ? t0 : t1;
    t[i] = best;
    hit[i] = (disc >= 0.0f) & (best > lo) & (best < hi) & (valid[i0 + i] == -1) ? -1 : 0;
  }
}

// The callbacks over sphere_lanes; Im is the peer's scene, whose member s is the prepared scene.
// lancer computes its own normal from the hit point: Embree gets a placeholder (0, 0, 1).
template <class Im>
struct UserSpheres {
  static void intersect(const RTCIntersectFunctionNArguments* args) {
    const auto& s = static_cast<const Im*>(args->geometryUserPtr)->s;
    const unsigned N = args->N, k = args->primID;
    auto* ray = reinterpret_cast<float*>(RTCRayHitN_RayN(args->rayhit, N));
    auto* hit = reinterpret_cast<float*>(RTCRayHitN_HitN(args->rayhit, N));
    const unsigned geom = args->geomID, inst = args->context->instID[0];
    alignas(64) float t[kLaneChunk];
    alignas(64) int h[kLaneChunk];
    alignas(64) static constexpr float zero[kLaneChunk] = {},
                                       one[kLaneChunk] = {1, 1, 1, 1, 1, 1, 1, 1,
                                                          1, 1, 1, 1, 1, 1, 1, 1};
    for (unsigned i0 = 0; i0 < N; i0 += kLaneChunk) {
      const unsigned n = std::min(kLaneChunk, N - i0);
      sphere_lanes(s, k, ray, N, i0, n, args->valid, t, h);
      store_hits(ray, hit, N, i0, n, h, t, zero, zero, one, k, geom, inst);
    }
  }
  static void occluded(const RTCOccludedFunctionNArguments* args) {
    const auto& s = static_cast<const Im*>(args->geometryUserPtr)->s;
    const unsigned N = args->N, k = args->primID;
    auto* ray = reinterpret_cast<float*>(args->ray);
    alignas(64) float t[kLaneChunk];
    alignas(64) int h[kLaneChunk];
    for (unsigned i0 = 0; i0 < N; i0 += kLaneChunk) {
      const unsigned n = std::min(kLaneChunk, N - i0);
      sphere_lanes(s, k, ray, N, i0, n, args->valid, t, h);
      select_lanes(ray + 8 * N + i0, h, -std::numeric_limits<float>::infinity(), int(n));
    }
  }
};

}  // namespace lancer::peer
