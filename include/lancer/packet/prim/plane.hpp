// The plane, a primitive module of the packets: unbounded, so outside the hierarchy; tested in
// id order after the bounded primitives (its ids are higher).
// Include only from code built for the batch's ISA (packet/kernel.hpp).
#pragma once

#include "lancer/packet/lane_traits.hpp"

namespace lancer::packet {

template <class Arch, class Real, class Mode>
struct PlanePackets : Lanes<Arch, Real, Mode> {
  using L = Lanes<Arch, Real, Mode>;
  using L::tests;
  using L::to_mi;
  using typename L::B;
  using typename L::I;
  using typename L::Id;
  using typename L::M;
  using typename L::Mth;
  using typename L::Scene;
  using typename L::V;

  // Where the ray (o, d) meets plane k; denom: d . n (0: parallel, no hit).
  [[gnu::always_inline]] static B plane_t(const Scene& s, int k, const V& o, const V& d,
                                          B& denom) noexcept {
    const V n{B(s.plane_nx[k]), B(s.plane_ny[k]), B(s.plane_nz[k])};
    denom = Mth::dot(d, n);
    return Mth::div(Mth::dot(V{B(s.plane_px[k]), B(s.plane_py[k]), B(s.plane_pz[k])} - o, n),
                    denom);
  }

  // The planes' part of closest_hit: after the spheres, in id order (their ids are higher).
  [[gnu::always_inline]] static void planes_closest(const Scene& s, const M& valid, const V& o,
                                                    const V& d, B& best_t, I& best_id,
                                                    RayCounts& counts) noexcept {
    const B eps(s.epsilon);
    for (int k = 0; k < s.num_planes; ++k) {
      tests(counts, valid, false);
      B denom;
      const B t = plane_t(s, k, o, d, denom);
      const M m = valid & (denom != B(0)) & (t > eps) & (t < best_t);
      best_t = xsimd::select(m, t, best_t);
      best_id = xsimd::select(to_mi(m), I(Id(s.num_spheres + k)), best_id);
    }
  }
};

}  // namespace lancer::packet
