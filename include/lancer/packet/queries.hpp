// The packets' two queries over every object of a scene: the closest hit (the bounded
// primitives through the hierarchy or a loop, then the planes) and shadow rays' any hit with its
// transmittance product, in the reference's order.
// Include only from code built for the batch's ISA (packet/kernel.hpp).
#pragma once

#include <limits>

#include "lancer/packet/hybrid.hpp"
#include "lancer/packet/primitives.hpp"

namespace lancer::packet {

template <class Arch, class Real, class Mode>
struct Queries : Hybrid<Arch, Real, Mode> {
  using Hy = Hybrid<Arch, Real, Mode>;
  using Prims = Primitives<Arch, Real, Mode>;
  using Hy::all_spheres;
  using Hy::bits;
  using Hy::count;
  using Hy::disc_of;
  using Hy::first_root;
  using Hy::gather;
  using Hy::gather8;
  using Hy::iota;
  using Hy::kBlockRows;
  using Hy::kFast;
  using Hy::kGroup;
  using Hy::kGroupPx;
  using Hy::kGroupX;
  using Hy::kGroupY;
  using Hy::kProfile;
  using Hy::kTileH;
  using Hy::kTileW;
  using Hy::lap;
  using Hy::leaf_spheres;
  using Hy::leaf_visit;
  using Hy::load_ids;
  using Hy::occupancy;
  using Hy::select3;
  using Hy::skip;
  using Hy::store_ids;
  using Hy::tests;
  using Hy::to_m;
  using Hy::to_mi;
  using Hy::W;
  using Hy::walk_choice;
  using typename Hy::B;
  using typename Hy::I;
  using typename Hy::Id;
  using typename Hy::M;
  using typename Hy::MI;
  using typename Hy::Mth;
  using typename Hy::Prepared;
  using typename Hy::Spheres;
  using typename Hy::T;
  using typename Hy::Tr;
  using typename Hy::V;

  // Closest hit over all objects for the lanes in `valid`. Updates t and id only where a nearer
  // hit is found (an equal t: a lower id); returns the lanes whose t is now finite.
  // Spheres through the hierarchy where the scene has one (and every lane starts within its
  // origin limit), else all in a loop; planes always in a loop, after the spheres (higher ids).
  // `leaving`: per lane, the sphere the ray leaves from outside (-1: none); see skip().
  // camera: the rays are camera rays (coherent: never one ray at a time).
  // Always inlined: with the ray tree's second copy of shade(), GCC stopped inlining it into
  // render_rows, and opaque scenes lost 5% to 15% at width 16.
  template <bool kFromEye = false>
  [[gnu::always_inline]] static M closest_hit(const Prepared& s, M valid, const V& o, const V& d,
                                              B& best_t, I& best_id, RayCounts& counts,
                                              const I& leaving = I(Id(-1)),
                                              bool camera = false) noexcept {
    if (spheres_alone(s)) {
      const int reach = !s.bvh.active() ? 2 : kFromEye ? 0 : Tr::reach(s.bvh, valid, o);
      if (reach < 2) {
        Hy::template closest_in_hierarchy<kFromEye>(s, reach, valid, o, d, best_t, best_id, counts,
                                                    leaving, camera);
      } else {
        Hy::template spheres_closest<kFromEye, true>(s, all_spheres(s), 0, s.num_spheres, valid, o,
                                                     d, best_t, best_id, counts, leaving);
      }
    }

    unbounded_closest(s, valid, o, d, best_t, best_id, counts);
    return valid & (best_t < B(std::numeric_limits<T>::infinity()));
  }

  // Whether the spheres are walked on their own (their hierarchy or loop): not where they are
  // leaves of the shapes' hierarchy too (one hierarchy over every bounded kind,
  // Features::spheres_in_shapes), which the kernels without shapes never meet.
  static bool spheres_alone(const Prepared& s) noexcept {
    if constexpr (Prims::kShapes)
      return Prims::Bounded::present(s) && !s.features.spheres_in_shapes;
    else
      return Prims::Bounded::present(s);
  }

  // The object ids of hit ids (meshes' hits carry their triangle: Primitives::Meshes).
  [[gnu::always_inline]] static I object_ids(const Prepared& s, const I& hit_id) noexcept {
    if (!Prims::Meshes::present(s)) return hit_id;
    return Prims::Meshes::object_of(s, hit_id);
  }

  // The unbounded kinds' part of closest_hit, after the hierarchy (their ids are higher).
  [[gnu::always_inline]] static void unbounded_closest(const Prepared& s, const M& valid,
                                                       const V& o, const V& d, B& best_t,
                                                       I& best_id, RayCounts& counts) noexcept {
    Prims::Unbounded::each([&](auto kind) __attribute__((always_inline)) {
      using K = KindOf<decltype(kind)>;
      if (K::present(s)) K::closest(s, valid, o, d, best_t, best_id, counts);
    });
  }

  // closest_hit for a camera block's kGX x kGY pinhole camera packets (tile g at column
  // g % kGX, row g / kGX): the spheres' hierarchy walked once for all of them; each unbounded
  // kind, in id order, for the whole block where it walks blocks (kBlocks), else tile by tile.
  // Per lane the kinds come in closest_hit's order, so the hits are closest_hit's.
  template <int kGX, int kGY>
  [[gnu::always_inline]] static void closest_camera_block(const Prepared& s, const M* valid,
                                                          const V* o, const V* d, B* best_t,
                                                          I* best_id, RayCounts& counts) noexcept {
    constexpr int n = kGX * kGY;
    if (spheres_alone(s)) {
      if (s.bvh.active()) {
        closest_group_in_hierarchy<n>(s, valid, o, d, best_t, best_id, counts);
      } else {
        for (int g = 0; g < n; ++g)
          Hy::template spheres_closest<true, true>(s, all_spheres(s), 0, s.num_spheres, valid[g],
                                                   o[g], d[g], best_t[g], best_id[g], counts,
                                                   I(Id(-1)));
      }
    }
    Prims::Unbounded::each([&](auto kind) __attribute__((always_inline)) {
      using K = KindOf<decltype(kind)>;
      if (!K::present(s)) return;
      if constexpr (K::kBlocks) {
        K::template closest_group<kGX, kGY>(s, valid, o, d, best_t, best_id, counts);
      } else {
        for (int g = 0; g < n; ++g)
          K::closest(s, valid[g], o[g], d[g], best_t[g], best_id[g], counts);
      }
    });
  }

  // The spheres of kN pinhole camera packets through the hierarchy at once
  // (Traversal::closest_coherent): one walk for tiles side by side.
  template <int kN>
  [[gnu::noinline]] static void closest_group_in_hierarchy(const Prepared& s, const M* valid,
                                                           const V* o, const V* d, B* best_t,
                                                           I* best_id, RayCounts& counts) noexcept {
    const Spheres sp = leaf_spheres(s);
    const I none(Id(-1));
    auto leaf = [&](int i, int first, int n, const M& m) {
      leaf_visit(counts, m);
      Hy::template spheres_closest<true, false>(s, sp, first, first + n, m, o[i], d[i], best_t[i],
                                                best_id[i], counts, none);
    };
    // The spheres of [first, first + n) that tile i's cone may meet (bits of which).
    auto some = [&](int i, int first, int n, const M& m, std::uint32_t which) {
      leaf_visit(counts, m);
      Hy::template spheres_closest<true, false, true>(s, sp, first, first + n, m, o[i], d[i],
                                                      best_t[i], best_id[i], counts, none, which);
    };
    // One functor, two calls: all of a leaf's spheres, or those of a mask.
    struct Leaves : decltype(leaf), decltype(some) {
      using decltype(leaf)::operator(), decltype(some)::operator();
    } leaves{leaf, some};
    if constexpr (kProfile)
      Tr::template closest_coherent<kN>(s.bvh, s.leaf_eye, valid, o, d, best_t, leaves,
                                        WalkCount{&counts.profile->blocks});
    else
      Tr::template closest_coherent<kN>(s.bvh, s.leaf_eye, valid, o, d, best_t, leaves);
  }
  // The camera blocks' walk counted into the profile (ProfiledMode only).
  struct WalkCount {
    StageProfile::Blocks* b;
    void block(bool together) const noexcept {
      ++(together ? b->together : b->alone);
      b->block_w = kGroupPx, b->block_h = kBlockRows;
    }
    void node() const noexcept { ++b->nodes; }
    void leaf_pop() const noexcept { ++b->leaf_pops; }
    void tile_test() const noexcept { ++b->tile_tests; }
    void leaf_call(unsigned lanes) const noexcept {
      ++b->leaf_calls;
      b->leaf_lanes += unsigned(__builtin_popcount(lanes));
    }
    void tile_alone() const noexcept { ++b->tiles_alone; }
    void cones(int pairs, int kept) const noexcept {
      b->cone_pairs += unsigned(pairs), b->cone_kept += unsigned(kept);
    }
  };

  // Any-hit for shadow rays from p along unit l, before `dist`: step(id, lanes, pending) for each
  // object the lanes' segments meet, once per lane, in the reference's order (spheres in the
  // hierarchy's or id order, planes, shapes: a float product of transmits depends on it); returns
  // the lanes of `valid` still pending, stopping when none is. Without transparency a step only
  // clears its lanes, and a kind may clear them itself (the shapes do). `leaving` as closest_hit's.
  template <bool kOneRay = false, class Step>
  [[gnu::always_inline]] static M any_hit(const Prepared& s, const M& valid, const V& p, const V& l,
                                          const B& dist, RayCounts& counts, const I& leaving,
                                          Step&& step) noexcept {
    using Bounded = typename Prims::Bounded;
    const B eps(s.epsilon);
    auto spheres = [&](const Spheres& sp, int begin, int end, const M& mask, M pending) {
      return Bounded::spheres_any(s, sp, begin, end, mask, pending, p, l, dist, eps, leaving,
                                  counts, step);
    };
    M pending = valid;
    if constexpr (Prims::kShapes)
      if (s.features.spheres_in_shapes && s.features.transparency)
        return any_in_one_hierarchy(s, valid, p, l, dist, eps, counts, step);
    if (spheres_alone(s)) {
      const int reach = s.bvh.active() ? Tr::reach(s.bvh, valid, p) : 2;
      if (reach < 2) {
        const Spheres sp = leaf_spheres(s);
        auto leaf = [&](int first, int n, const M& mask, const M& pend) {
          leaf_visit(counts, mask & pend);
          return spheres(sp, first, first + n, mask, pend);
        };
        if constexpr (kOneRay)
          pending = reach == 0
                        ? Hy::template any_one_ray<false>(s, valid, p, l, dist, counts, leaf, step)
                        : Hy::template any_one_ray<true>(s, valid, p, l, dist, counts, leaf, step);
        else
          pending = reach == 0 ? Tr::template any<false>(s.bvh, valid, p, l, dist, leaf)
                               : Tr::template any<true>(s.bvh, valid, p, l, dist, leaf);
      } else {
        pending = spheres(all_spheres(s), 0, s.num_spheres, valid, valid);
      }
      if (!xsimd::any(pending)) return pending;
    }
    bool done = false;  // no lane pending: the kinds after are not tested
    Prims::Unbounded::each([&](auto kind) __attribute__((always_inline)) {
      using K = KindOf<decltype(kind)>;
      if (done || !K::present(s)) return;
      pending = K::any(s, pending, p, l, dist, eps, counts, step);
      done = !xsimd::any(pending);
    });
    return pending;
  }

  // any_hit where the spheres are leaves of the shapes' hierarchy and objects transmit: the
  // walk's objects in id order around the other unbounded kinds', whose ids lie between the
  // spheres' and the shapes' (opaque scenes need no order: any_hit's own).
  template <class Step>
  [[gnu::noinline]] static M any_in_one_hierarchy(const Prepared& s, const M& valid, V p, V l,
                                                  B dist, B eps, RayCounts& counts,
                                                  Step& step) noexcept {
    using Shapes = typename Prims::Shapes;
    auto between = [&](M pending) {
      Prims::Unbounded::each([&](auto kind) {
        using K = KindOf<decltype(kind)>;
        if constexpr (!std::is_same_v<K, Shapes>)
          if (K::present(s) && xsimd::any(pending))
            pending = K::any(s, pending, p, l, dist, eps, counts, step);
      });
      return pending;
    };
    return Shapes::any_around(s, valid, p, l, dist, eps, counts, step, between);
  }

  // A packet of shadow rays under way: the lanes still looking for what they meet, and each
  // lane's transmittance so far (contract step 4; stays 1 in scenes without transparency).
  struct Shadow {
    M pending;
    B transmittance;
  };

  // The any-hit query's per-object step: the lanes of `met` meet object `id` (nearest hit beyond
  // epsilon, nearer than the light). Their transmittance is multiplied by its transmit; a lane
  // is done once that is 0. Without transparency every object is opaque: done at once, no
  // product. kGlass false: the scene has no transparency (compiled out of the grey opaque path).
  template <bool kGlass>
  static void shadow_hit(const Prepared& s, Shadow& sh, const M& met, Id id) noexcept {
    if (!kGlass || !s.features.transparency) {
      sh.pending = sh.pending & ~met;
      return;
    }
    sh.transmittance =
        xsimd::select(met, attenuate(sh.transmittance, B(s.materials.transmit[std::size_t(id)])),
                      sh.transmittance);
    sh.pending = sh.pending & ~(met & (sh.transmittance == B(0)));
  }

  // Shadow rays from p along unit l towards lights at `dist`: each lane's transmittance over
  // the objects it meets; `pending` keeps the lanes whose transmittance is not 0 (in opaque
  // scenes, those not blocked). `leaving` as for closest_hit.
  // Always inlined: with the 4-wide traversal in any_hit, GCC stopped inlining it into
  // render_rows, and course scenes ran 6% to 9% more instructions (callgrind, widths 4 and 8).
  template <bool kGlass, bool kOneRay = true>
  [[gnu::always_inline]] static Shadow occluded(const Prepared& s, M valid, const V& p, const V& l,
                                                const B& dist, RayCounts& counts, const I& leaving,
                                                bool secondary = false) noexcept {
    if constexpr (kOneRay && !kFast)
      if (__builtin_expect(secondary && s.walk.shadow_one_ray_lanes > 0, 0))
        return occluded_one_ray<kGlass>(s, valid, p, l, dist, counts);
    return occluded_as<kGlass, false>(s, valid, p, l, dist, counts, leaving);
  }
  template <bool kGlass, bool kOneRay>
  [[gnu::always_inline]] static Shadow occluded_as(const Prepared& s, const M& valid, const V& p,
                                                   const V& l, const B& dist, RayCounts& counts,
                                                   const I& leaving) noexcept {
    Shadow sh{valid, B(T(1))};
    sh.pending = any_hit<kOneRay>(s, valid, p, l, dist, counts, leaving,
                                  [&](Id id, const M& met, const M& pending) {
                                    sh.pending = pending;
                                    shadow_hit<kGlass>(s, sh, met, id);
                                    return sh.pending;
                                  });
    return sh;
  }
  // Shadow rays of secondary hits through a hierarchy, lanes alone where the scene says (exact
  // float and double). Out of line and by value: the shading loops that inline `occluded` keep
  // their vectors in registers (a reference passed out would give them a home in memory; the
  // course scenes ran 2-3% more instructions in render_rows, callgrind).
  template <bool kGlass>
  [[gnu::noinline]] static Shadow occluded_one_ray(const Prepared& s, M valid, V p, V l, B dist,
                                                   RayCounts& counts) noexcept {
    return occluded_as<kGlass, true>(s, valid, p, l, dist, counts, I(Id(-1)));
  }
};

}  // namespace lancer::packet
