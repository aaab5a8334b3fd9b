// The library API's hits written out (src/engine/api.cpp): every field of a packet's lanes, the
// geometric normal of each lane that hit a sphere or a plane in world space, by the kernel's ISA
// a packet at a time. The same formulas as the API's scalar world_normal (formulas.hpp,
// ExactMath, whatever the kernel's mode), chosen per lane as it chooses them, so every lane gets
// its bits. Include only from code built for the batch's ISA (src/isa/*.cpp, through
// packet/kernel.hpp).
#pragma once

#include <cstdint>
#include <cstring>

#include "lancer/packet/api_rays.hpp"
#include "lancer/packet/lane_traits.hpp"

namespace lancer::packet {

// x's bits where keep's are set, other's elsewhere.
inline float masked(float x, std::uint32_t keep, std::uint32_t other) noexcept {
  std::uint32_t b;
  std::memcpy(&b, &x, sizeof b);
  b = (b & keep) | (other & ~keep);
  std::memcpy(&x, &b, sizeof x);
  return x;
}

// n lanes' hit fields (HitLanes): id as given; for a miss (id < 0) t infinity, primitive -1
// and a zero normal; else t rounded to float, primitive 0 (a sphere or a plane is one primitive)
// and the object-space normal moved to world space, Frame::world_direction written out in double
// (u n.x + v n.y, then + w n.z; the normal itself where the frame keeps the world's axes) and
// rounded once to float; u = v = 0. A plain loop over restrict arrays without a branch,
// vectorised as frame_rays is.
template <bool Axes, class T>
[[gnu::always_inline]] inline void world_hits_loop(
    const Frame& frame, int n, const T* __restrict nx, const T* __restrict ny,
    const T* __restrict nz, const T* __restrict t, const std::int32_t* __restrict id,
    float* __restrict t_out, float* __restrict gx, float* __restrict gy, float* __restrict gz,
    float* __restrict u, float* __restrict v, int* __restrict prim_out,
    int* __restrict id_out) noexcept {
  const double ux = frame.u.x, uy = frame.u.y, uz = frame.u.z;
  const double vx = frame.v.x, vy = frame.v.y, vz = frame.v.z;
  const double wx = frame.w.x, wy = frame.w.y, wz = frame.w.z;
  const std::uint32_t inf = 0x7f800000u;  // +infinity's bits
  for (int l = 0; l < n; ++l) {
    // A hit's fields by bitwise masks, not by a select of the float values: GCC would compute
    // them only for hits, behind a branch it cannot turn back into vectors (its float
    // operations may trap), and not vectorise the loop.
    const std::uint32_t keep = id[l] < 0 ? 0u : ~0u;
    if constexpr (Axes) {
      gx[l] = masked(float(nx[l]), keep, 0u);
      gy[l] = masked(float(ny[l]), keep, 0u);
      gz[l] = masked(float(nz[l]), keep, 0u);
    } else {
      const double a = nx[l], b = ny[l], c = nz[l];
      gx[l] = masked(float((ux * a + vx * b) + wx * c), keep, 0u);
      gy[l] = masked(float((uy * a + vy * b) + wy * c), keep, 0u);
      gz[l] = masked(float((uz * a + vz * b) + wz * c), keep, 0u);
    }
    t_out[l] = masked(float(t[l]), keep, inf);
    u[l] = 0.0f, v[l] = 0.0f;
    prim_out[l] = ~int(keep);  // -1 for a miss, 0 (a sphere or a plane is one primitive)
    id_out[l] = id[l];
  }
}

template <class Arch, class T>
void world_hits(const Frame& frame, int n, const T* __restrict nx, const T* __restrict ny,
                const T* __restrict nz, const T* __restrict t, const std::int32_t* __restrict id,
                float* __restrict t_out, float* __restrict gx, float* __restrict gy,
                float* __restrict gz, float* __restrict u, float* __restrict v,
                int* __restrict prim_out, int* __restrict id_out) noexcept {
  if (frame.axes)
    world_hits_loop<true>(frame, n, nx, ny, nz, t, id, t_out, gx, gy, gz, u, v, prim_out, id_out);
  else
    world_hits_loop<false>(frame, n, nx, ny, nz, t, id, t_out, gx, gy, gz, u, v, prim_out, id_out);
}

// One chunk of the API's width-W lanes (rays as closest_hit_packet's, t and id as it left
// them) into the W lanes of `out` (world_hits), the normal of a lane whose id is a sphere or a
// plane the one world_normal gives: sphere_point_along's, sphere_point_local's where the sphere
// is small against the hit's magnitude, sphere_point_large's where it is huge. A lane whose id is
// a triangle, mesh or cylinder gets a zero normal (the caller's to rewrite).
template <class Arch, class Real>
void hit_fields(const PreparedScene<Real>& s, const Real* rays, const Real* t,
                const std::int32_t* ids, const HitLanes& out) noexcept {
  using L = Lanes<Arch, Real, ExactMode>;
  using B = typename L::B;
  using M = typename L::M;
  using V = typename L::V;
  using I = typename L::I;
  using Id = typename L::Id;
  constexpr int W = L::W;
  const V o{B::load_unaligned(rays), B::load_unaligned(rays + W), B::load_unaligned(rays + 2 * W)};
  const V d{B::load_unaligned(rays + 3 * W), B::load_unaligned(rays + 4 * W),
            B::load_unaligned(rays + 5 * W)};
  const B tt = B::load_unaligned(t);
  const I id = L::load_ids(ids);
  const int ns = s.num_spheres, np = s.num_planes;
  V n{B(0), B(0), B(0)};
  if (np > 0) {
    const M plane = L::to_m((id >= I(Id(ns))) & (id < I(Id(ns + np))));
    const I pid = xsimd::max(xsimd::min(id - I(Id(ns)), I(Id(np - 1))), I(Id(0)));
    const V pn{L::gather(s.planes.nx, pid, np), L::gather(s.planes.ny, pid, np),
               L::gather(s.planes.nz, pid, np)};
    n = L::select3(plane, pn, n);
  }
  const M sphere = L::to_m((id >= I(Id(0))) & (id < I(Id(ns))));
  if (ns > 0 && xsimd::any(sphere)) {
    // The centres from the hierarchy's leaf copy where there is one (the same bits; the walk
    // has just read the hit sphere's lines), each lane's position looked up by its id. Not at
    // W spheres or fewer: gather then loads a whole register, from the id-order arrays' padding.
    const Bvh<Real>& h = s.bvh;
    const bool leaves = ns > W && !h.leaf_of.empty();
    I sid = xsimd::max(xsimd::min(id, I(Id(ns - 1))), I(Id(0)));
    if (leaves) {
      alignas(64) Id at[W];
      sid.store_aligned(at);
      for (int k = 0; k < W; ++k) at[k] = Id(h.leaf_of[std::size_t(at[k])]);
      sid = I::load_aligned(at);
    }
    const auto& cx = leaves ? h.cx : s.spheres.cx;
    const auto& cy = leaves ? h.cy : s.spheres.cy;
    const auto& cz = leaves ? h.cz : s.spheres.cz;
    const auto& sr2 = leaves ? h.r2 : s.spheres.r2;
    const V c{L::gather(cx, sid, ns), L::gather(cy, sid, ns), L::gather(cz, sid, ns)};
    const B r2 = L::gather(sr2, sid, ns);
    const B m = hit_magnitude(o, tt);
    V sn = sphere_point_along<Real>(o, d, tt, c, m).normal;
    // world_normal's order: small first, large only where not small.
    const M small = sphere & sphere_is_small(r2, m);
    if (xsimd::any(small))
      sn = L::select3(small, sphere_point_local<Real>(o, d, tt, c, r2).normal, sn);
    const M large = sphere & ~small & sphere_is_large(r2, m);
    if (xsimd::any(large))
      sn = L::select3(large, sphere_point_large<Real>(o, d, tt, c, r2, m).normal, sn);
    n = L::select3(sphere, sn, n);
  }
  alignas(64) Real nx[W], ny[W], nz[W];
  n.x.store_aligned(nx), n.y.store_aligned(ny), n.z.store_aligned(nz);
  world_hits<Arch, Real>(s.frame, W, nx, ny, nz, t, ids, out.t, out.ng_x, out.ng_y, out.ng_z, out.u,
                         out.v, out.prim_id, out.id);
}

}  // namespace lancer::packet
