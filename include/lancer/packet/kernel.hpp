// The packet kernels, one source for every width and precision: Kernel<Arch, Real, Mode> works
// on the lanes of one xsimd::batch<Real, Arch> at once, structure-of-arrays. Include only from
// src/isa/*.cpp (built with that ISA's flags) and instantiate there through table<>().
//
// The pipeline, a stage a header, each built on the ones before (docs/architecture.md):
//   lane_traits.hpp       lane types, maths policy, profiling hooks
//   prim/sphere.hpp       primitive modules: their ray tests
//   prim/plane.hpp
//   hybrid.hpp            the hierarchy's walks with lanes alone (traversal.hpp: the walks)
//   queries.hpp           closest hit and shadow rays over every object
//   shading.hpp           hit points, normals, lights, reflected and refracted rays
//   radiance.hpp          a packet's radiance: the reflections' chain or the ray tree
//   camera.hpp            camera rays, tiles and blocks
//   rows.hpp              rows of pixels, primary hits, the kernel alone
// Conventions (after Embree's intersectors): a kernel takes a `valid` mask, narrows it test by
// test, and never writes a lane outside it. Kernels are noexcept; they report through masks.
// Exact mode: every formula comes from formulas.hpp with ExactMath, as in the reference, in the
// same order, so every lane computes the reference's bits.
#pragma once

#include "lancer/packet/api_hits.hpp"
#include "lancer/packet/api_rays.hpp"
#include "lancer/packet/rows.hpp"

namespace lancer::packet {

template <class Arch, class Real, class Mode>
struct Kernel : Rows<Arch, Real, Mode> {
  using Ro = Rows<Arch, Real, Mode>;
  using Ro::bits;
  using Ro::closest_hit;
  using Ro::load_ids;
  using Ro::store_ids;
  using Ro::W;
  using typename Ro::B;
  using typename Ro::I;
  using typename Ro::M;
  using typename Ro::Prepared;
  using typename Ro::T;
  using typename Ro::V;

  static void closest_hit_packet(const Prepared& s, const bool* valid, const T* rays, T* t,
                                 std::int32_t* id, bool* hit_out, std::int32_t* prim_out) noexcept {
    const M v = M::load_unaligned(valid);
    const V o{B::load_unaligned(rays), B::load_unaligned(rays + W),
              B::load_unaligned(rays + 2 * W)};
    const V d{B::load_unaligned(rays + 3 * W), B::load_unaligned(rays + 4 * W),
              B::load_unaligned(rays + 5 * W)};
    B bt = B::load_unaligned(t);
    I bid = load_ids(id);
    RayCounts unused;
    const M hit = closest_hit(s, v, o, d, bt, bid, unused);
    bt.store_unaligned(t);
    store_ids(Ro::object_ids(s, bid), id, W);
    if (prim_out) {
      // A shape's hit id is first_id + its primitive number (prim/shapes.hpp).
      using Meshes = typename Ro::Prims::Meshes;
      const I first(typename Ro::Id(Meshes::first_id(s)));
      store_ids(xsimd::select(bid >= first, bid - first, I(-1)), prim_out, W);
    }
    const unsigned hb = bits(hit);
    for (int k = 0; k < W; ++k) hit_out[k] = (hb >> k) & 1u;
  }

  static void occluded_packet(const Prepared& s, const bool* valid, const T* rays, const T* tfar,
                              bool* blocked_out) noexcept {
    const M v = M::load_unaligned(valid);
    const V o{B::load_unaligned(rays), B::load_unaligned(rays + W),
              B::load_unaligned(rays + 2 * W)};
    const V d{B::load_unaligned(rays + 3 * W), B::load_unaligned(rays + 4 * W),
              B::load_unaligned(rays + 5 * W)};
    RayCounts unused;
    // No sphere is being left (-1): the rays start wherever the caller put them.
    // Any object blocks here (kGlass false): the API's occlusion is a yes/no query.
    const unsigned bb = bits(
        v &
        ~Ro::template occluded<false>(s, v, o, d, B::load_unaligned(tfar), unused, I(-1)).pending);
    for (int k = 0; k < W; ++k) blocked_out[k] = (bb >> k) & 1u;
  }

  // A caller's packet of n lanes (a multiple of W, at most kMaxLanes) straight from its arrays,
  // in one call: every lane checked and moved into the frame in one pass (take_rays), then
  // traced W at a time, and the answers written out. Only a plain packet (every lane on, seeing
  // some object, from epsilon) is traced: else nothing is written and the result is take_rays'
  // bits (bit 0, some live lane fails the checks), for the caller's chunked path, which names
  // the failing lane. Returns 2 when done.
  static int take_packet(const Prepared& s, const RayLanes& r, int n, T* rays) noexcept {
    int bad = 0, plain = 1;
    for (int c = 0; c < n; c += W) {
      const int scan = take_rays<W>(s.frame, r.from(c), s.epsilon, rays + 6 * c);
      bad |= scan & 1, plain &= scan >> 1;
    }
    return bad | plain << 1;
  }
  static V row3(const T* rays) noexcept {
    return {B::load_aligned(rays), B::load_aligned(rays + W), B::load_aligned(rays + 2 * W)};
  }
  static B tfar_of(const float* tfar) noexcept {
    alignas(64) T t[W];
    for (int k = 0; k < W; ++k) t[k] = T(tfar[k]);
    return B::load_aligned(t);
  }
  static int intersect_lanes(const Prepared& s, const RayLanes& r, int n, const HitLanes& out,
                             const ShapeLanes<T>* shapes) noexcept {
    alignas(64) T own[6 * kMaxLanes];
    T* rays = shapes ? shapes->rays : own;
    const int scan = take_packet(s, r, n, rays);
    if (scan != 2) return scan;
    for (int c = 0; c < n; c += W) {
      const T* chunk = rays + 6 * c;
      B bt = tfar_of(r.tfar + c);
      I bid(-1);
      RayCounts unused;
      closest_hit(s, M(true), row3(chunk), row3(chunk + 3 * W), bt, bid, unused);
      alignas(64) T t[W];
      alignas(64) std::int32_t id[W];
      bt.store_aligned(t);
      store_ids(Ro::object_ids(s, bid), id, W);
      hit_fields<Arch, Real>(s, chunk, t, id, out.from(c));
      if (shapes) {
        // A shape's hit id is first_id + its primitive number (prim/shapes.hpp).
        const I first(typename Ro::Id(Ro::Prims::Meshes::first_id(s)));
        store_ids(xsimd::select(bid >= first, bid - first, I(-1)), shapes->prim + c, W);
        bt.store_unaligned(shapes->t + c);
      }
    }
    return scan;
  }
  static int occluded_lanes(const Prepared& s, const RayLanes& r, int n,
                            int* blocked_out) noexcept {
    alignas(64) T rays[6 * kMaxLanes];
    const int scan = take_packet(s, r, n, rays);
    if (scan != 2) return scan;
    for (int c = 0; c < n; c += W) {
      const T* chunk = rays + 6 * c;
      RayCounts unused;
      const M all(true);
      const unsigned bb =
          bits(~Ro::template occluded<false>(s, all, row3(chunk), row3(chunk + 3 * W),
                                             tfar_of(r.tfar + c), unused, I(-1))
                    .pending);
      for (int k = 0; k < W; ++k) blocked_out[c + k] = int((bb >> k) & 1u);
    }
    return scan;
  }
};

// The table of one instantiation, made on first use inside this ISA's own code: the dispatcher
// calls it only once the CPU check has passed, so no instruction of the ISA runs before.
template <class Arch, class Real, class Mode>
const KernelTable<Real>* table() {
  using K = Kernel<Arch, Real, Mode>;
  static const KernelTable<Real> t{K::W,
                                   Arch::name(),
                                   ModeTraits<Mode>::kShapes
                                       ? "every kind (spheres, planes, triangles, meshes, "
                                         "cylinders)"
                                       : "spheres and planes alone",
                                   &K::render_rows,
                                   &K::primary_rows,
                                   &K::camera_packet_count,
                                   &K::camera_packets,
                                   &K::intersect_camera_packets,
                                   &K::closest_hit_packet,
                                   &K::occluded_packet,
                                   &K::intersect_lanes,
                                   &K::occluded_lanes,
                                   &frame_rays<Arch, Real>,
                                   &scan_rays<Arch, Real>,
                                   &hit_fields<Arch, Real>};
  return &t;
}

}  // namespace lancer::packet
