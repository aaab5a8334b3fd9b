// The plane, a primitive module of the packets: unbounded, so outside the hierarchy; tested in
// id order after the bounded primitives (its ids are higher).
// Include only from code built for the batch's ISA (packet/kernel.hpp).
#pragma once

#include "lancer/packet/lane_traits.hpp"

namespace lancer::packet {

template <class Arch, class Real, class Mode>
struct PlanePackets : Lanes<Arch, Real, Mode> {
  using L = Lanes<Arch, Real, Mode>;
  using L::gather;
  using L::select3;
  using L::tests;
  using L::to_m;
  using L::to_mi;
  using typename L::B;
  using typename L::I;
  using typename L::Id;
  using typename L::M;
  using typename L::Mth;
  using typename L::Prepared;
  using typename L::V;

  // Where the ray (o, d) meets plane k; denom: d . n (0: parallel, no hit).
  [[gnu::always_inline]] static B plane_t(const Prepared& s, int k, const V& o, const V& d,
                                          B& denom) noexcept {
    const V n{B(s.planes.nx[k]), B(s.planes.ny[k]), B(s.planes.nz[k])};
    denom = Mth::dot(d, n);
    return Mth::div(Mth::dot(V{B(s.planes.px[k]), B(s.planes.py[k]), B(s.planes.pz[k])} - o, n),
                    denom);
  }

  // Whether the scene has planes.
  static bool present(const Prepared& s) noexcept { return s.features.planes; }
  // The first plane's object id: planes come after the bounded kinds, in file order.
  static int first_id(const Prepared& s) noexcept { return s.num_spheres; }

  // Camera blocks test their tiles one by one (no closest_group).
  static constexpr bool kBlocks = false;
  // Closest hit over the planes for the lanes of `valid`, in id order: a nearer t wins.
  [[gnu::always_inline]] static void closest(const Prepared& s, const M& valid, const V& o,
                                             const V& d, B& best_t, I& best_id,
                                             RayCounts& counts) noexcept {
    const B eps(s.epsilon);
    for (int k = 0; k < s.num_planes; ++k) {
      tests(counts, valid, false);
      B denom;
      const B t = plane_t(s, k, o, d, denom);
      const M m = valid & (denom != B(0)) & (t > eps) & (t < best_t);
      best_t = xsimd::select(m, t, best_t);
      best_id = xsimd::select(to_mi(m), I(Id(first_id(s) + k)), best_id);
    }
  }

  // Any hit over the planes for the lanes still pending, from p along unit l before `dist`:
  // step(id, lanes, pending) for each plane the lanes meet beyond eps, in id order, until none
  // is pending.
  template <class Step>
  [[gnu::always_inline]] static M any(const Prepared& s, M pending, const V& p, const V& l,
                                      const B& dist, const B& eps, RayCounts& counts,
                                      Step& step) noexcept {
    for (int k = 0; k < s.num_planes; ++k) {
      tests(counts, pending, false);
      B denom;
      const B t = plane_t(s, k, p, l, denom);
      const M m = pending & (denom != B(0)) & (t > eps) & (t < dist);
      if (!xsimd::any(m)) continue;
      pending = step(Id(first_id(s) + k), m, pending);
      if (!xsimd::any(pending)) return pending;
    }
    return pending;
  }

  // The surface at the hits: plane id - first_id's normal, for the lanes whose hit is a plane.
  [[gnu::always_inline]] static void surface(const Prepared& s, const M& hit, const I& best_id,
                                             const I& id, const V& o, const V& d, const B& best_t,
                                             const B& magnitude, V& p, V& n, B& delta) noexcept {
    const int first = first_id(s);
    const int np = s.num_planes;
    // Clamped into the planes: lanes of later kinds (shapes) read plane np - 1 (and are
    // overwritten); kernels built without shapes have none.
    I pid = xsimd::max(id - I(Id(first)), I(0));
    if constexpr (ModeTraits<Mode>::kShapes) pid = xsimd::min(pid, I(Id(np - 1)));
    const V pn{gather(s.planes.nx, pid, np), gather(s.planes.ny, pid, np),
               gather(s.planes.nz, pid, np)};
    n = first > 0 ? select3(to_m(best_id < I(Id(first))), n, pn) : pn;
  }
};

}  // namespace lancer::packet
