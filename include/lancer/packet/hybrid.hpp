// The hybrid switch (Benthin et al.): a packet's closest-hit walk through the hierarchy, whose
// lanes go on one ray at a time where the scene says (exact float and double) and they do not
// stay together; and the shadow rays' walk likewise.
// Include only from code built for the batch's ISA (packet/kernel.hpp).
#pragma once

#include <cmath>

#include "lancer/packet/prim/sphere.hpp"

namespace lancer::packet {

template <class Arch, class Real, class Mode>
struct Hybrid : SpherePackets<Arch, Real, Mode> {
  using Sph = SpherePackets<Arch, Real, Mode>;
  using Sph::count;
  using Sph::iota;
  using Sph::kFast;
  using Sph::kProfile;
  using Sph::leaf_spheres;
  using Sph::leaf_visit;
  using Sph::spheres_closest_one;
  using Sph::spheres_one;
  using Sph::W;
  using Sph::walk_choice;
  using typename Sph::B;
  using typename Sph::I;
  using typename Sph::Id;
  using typename Sph::M;
  using typename Sph::Prepared;
  using typename Sph::Spheres;
  using typename Sph::T;
  using typename Sph::Tr;
  using typename Sph::V;

  // The spheres through the hierarchy (reach 0 or 1: Traversal::reach). Out of line: inlined
  // into closest_hit, the 4-wide traversal changed the code GCC made for the plain loop around
  // it (course scenes, no hierarchy: 2.5% more instructions at width 8, callgrind).
  // camera: camera rays (orthographic ones come here), which stay packets: they are coherent.
  template <bool kFromEye>
  [[gnu::noinline]] static void closest_in_hierarchy(const Prepared& s, int reach, M valid,
                                                     const V& o, const V& d, B& best_t, I& best_id,
                                                     RayCounts& counts, const I& leaving,
                                                     bool camera) noexcept {
    const Spheres sp = leaf_spheres(s);
    auto leaf = [&](int first, int n, const M& m) {
      leaf_visit(counts, m);
      Sph::template spheres_closest<kFromEye, false>(s, sp, first, first + n, m, o, d, best_t,
                                                     best_id, counts, leaving);
    };
    // Exact float and double: where the scene says (WalkSettings::one_ray_lanes,
    // clustered_lanes), secondary rays' lanes go on one ray at a time, unless they stay together
    // (secondary_walk).
    if constexpr (!kFromEye && !kFast) {
      const bool clusters = clusters_at(s.walk.clustered_lanes, s.walk.one_ray_lanes, W);
      if ((s.walk.one_ray_lanes > 0 || clusters) && !camera) {
        const SecondaryWalk how = secondary_walk(s, valid, o, d, clusters);
        walk_choice(counts, how);
        if (how != SecondaryWalk::whole) {
          const int lanes =
              how == SecondaryWalk::clustered ? s.walk.clustered_lanes : s.walk.one_ray_lanes;
          auto walk = [&](auto padded) {
            constexpr bool kPadded = decltype(padded)::value;
            OneRay<kPadded> one{s, o, d, best_t, best_id, counts, lanes, {}};
            Tr::template closest<kPadded>(s.bvh, valid, o, d, best_t, leaf, one);
          };
          reach == 0 ? walk(std::false_type{}) : walk(std::true_type{});
          return;
        }
      }
    }
    if (reach == 0)
      Tr::template closest<false>(s.bvh, valid, o, d, best_t, leaf);
    else
      Tr::template closest<true>(s.bvh, valid, o, d, best_t, leaf);
  }
  // How a secondary packet walks where its scene sends such rays one at a time: whole where its
  // live lanes stay together through the hierarchy (Bvh::coherent_spread: the spread of their
  // origins plus that of their directions over the structure's diagonal); clustered where they
  // leave from within one leaf box (Bvh::leaf_diagonal) and the scene walks such packets apart
  // (`clusters`: clusters_at, WalkSettings::clustered_lanes); else apart, or whole where only
  // clustered packets' lanes go alone (WalkSettings::one_ray_lanes 0). Coherent packets (a flat
  // mirror's, camera rays through the library API) walk 2x faster whole than lane by lane at 65536
  // spheres, diverging ones 1.3x-1.5x slower; diffuse rays, four from each hit point, 1.15x faster
  // clustered.
  [[gnu::noinline]] static SecondaryWalk secondary_walk(const Prepared& s, const M& valid,
                                                        const V& o, const V& d,
                                                        bool clusters) noexcept {
    auto span = [&](const B& x) { return Tr::live_span(valid, x); };
    const T ox = span(o.x), oy = span(o.y), oz = span(o.z);
    const T dx = span(d.x), dy = span(d.y), dz = span(d.z);
    const T origins = std::sqrt(ox * ox + oy * oy + oz * oz);
    if (origins + s.bvh.diagonal * std::sqrt(dx * dx + dy * dy + dz * dz) <= s.bvh.coherent_spread)
      return SecondaryWalk::whole;
    if (clusters && origins <= s.bvh.leaf_diagonal) return SecondaryWalk::clustered;
    return s.walk.one_ray_lanes > 0 ? SecondaryWalk::apart : SecondaryWalk::whole;
  }
  // A packet's rays lane by lane, stored when a first lane goes on alone.
  struct LaneRays {
    alignas(64) T ox[W], oy[W], oz[W], dx[W], dy[W], dz[W];
    bool stored = false;
    void store(const V& o, const V& d) noexcept {
      if (stored) return;
      o.x.store_aligned(ox), o.y.store_aligned(oy), o.z.store_aligned(oz);
      d.x.store_aligned(dx), d.y.store_aligned(dy), d.z.store_aligned(dz);
      stored = true;
    }
    void get(int k, T* o, T* d) const noexcept {
      o[0] = ox[k], o[1] = oy[k], o[2] = oz[k], d[0] = dx[k], d[1] = dy[k], d[2] = dz[k];
    }
  };
  // The lanes `lanes` of a packet going on alone, in lane order: their rays and slab forms.
  struct LoneRays {
    typename Tr::OneRay4 slab[W];
    T o[W][3], d[W][3];
    int lane[W];
    int n = 0;
    LoneRays(const LaneRays& rays, unsigned lanes, bool padded) noexcept {
      for (; lanes; lanes &= lanes - 1, ++n) {
        const int k = lane[n] = __builtin_ctz(lanes);
        rays.get(k, o[n], d[n]);
        slab[n] = Tr::one_ray(o[n], d[n], padded);
      }
    }
  };
  // A leaf visited by one lane alone (lancer profile: one call, one lane live).
  static void one_leaf_visit(RayCounts& c, int spheres) noexcept {
    if constexpr (kProfile) {
      c.profile->leaf_packets[c.profile->current] += 1;
      c.profile->leaf_lanes[c.profile->current] += 1;
      c.profile->sphere_tests += std::uint64_t(spheres);
    }
  }
  // A secondary packet's lanes walking a subtree one ray at a time (exact float and double; the
  // hybrid step of Traversal::closest): each lane's ray over the wide nodes alone, the lanes'
  // walks interleaved (Traversal::closest_one), its leaves' spheres a register at a time
  // (spheres_closest_one).
  template <bool kPadded>
  struct OneRay {
    static constexpr int kMaxLanes = W;
    const Prepared& s;
    const V& o;
    const V& d;
    B& best_t;
    I& best_id;
    RayCounts& counts;
    int limit;  // lanes at or below which they go on alone
    LaneRays rays;
    void operator()(unsigned lanes, std::int32_t child, std::int32_t count) noexcept {
      rays.store(o, d);
      alignas(64) T bt[W];
      alignas(64) Id bi[W];
      best_t.store_aligned(bt);
      best_id.store_aligned(bi);
      // Every lane's walk at once, interleaved (Traversal::closest_one).
      const LoneRays lone(rays, lanes, kPadded);
      const T* best[W];
      for (int i = 0; i < lone.n; ++i) best[i] = &bt[lone.lane[i]];
      Tr::template closest_one<kPadded, W>(
          s.bvh, lone.slab, lone.n, child, count, best, [&](int i, int first, int m) {
            const int k = lone.lane[i];
            one_leaf_visit(counts, m);
            spheres_closest_one(s, first, m, lone.o[i], lone.d[i], bt[k], bi[k]);
          });
      best_t = B::load_aligned(bt);
      best_id = I::load_aligned(bi);
    }
  };

  // A shadow packet's lanes walking a subtree one ray at a time (exact float and double; the
  // hybrid step of Traversal::any): each pending lane's segment over the wide nodes alone in the
  // fixed slot order, the lanes' walks interleaved (Traversal::any_one), its leaves' spheres a
  // register at a time; step(id, lane, pending) for each sphere a lane meets before the light,
  // in leaf order for that lane, until the lane is no longer pending (steps of different lanes
  // touch different lanes only, so their interleaving changes nothing).
  template <bool kPadded, class Step>
  struct OneShadow {
    static constexpr int kMaxLanes = W;
    const Prepared& s;
    const V& p;
    const V& l;
    const B& dist;
    Step& step;
    RayCounts& counts;
    int limit;  // lanes at or below which they go on alone
    LaneRays rays;
    alignas(64) T dd[W];
    M operator()(unsigned lanes, std::int32_t child, std::int32_t count, M pending) noexcept {
      if (!rays.stored) dist.store_aligned(dd);
      rays.store(p, l);
      const B index = iota();
      // Every lane's walk at once, interleaved.
      const LoneRays lone(rays, lanes, kPadded);
      const T* tmax[W];
      for (int i = 0; i < lone.n; ++i) tmax[i] = &dd[lone.lane[i]];
      auto leaf = [&](int i, int first, int m) {
        one_leaf_visit(counts, m);
        const M mine = index == B(T(lone.lane[i]));
        return spheres_one(s, first, m, lone.o[i], lone.d[i], [&](int j, T t) {
          if (!(t < *tmax[i])) return false;
          pending = step(Id(s.bvh.id[std::size_t(j)]), mine, pending);
          return !xsimd::any(pending & mine);
        });
      };
      // One lane (the usual case at limit 1) walks without the others' stacks.
      if (lone.n == 1)
        Tr::template any_one<kPadded, 1>(s.bvh, lone.slab, 1, child, count, tmax, leaf);
      else
        Tr::template any_one<kPadded, W>(s.bvh, lone.slab, lone.n, child, count, tmax, leaf);
      return pending;
    }
  };
  // The hierarchy's any-hit walk with lanes going on alone (OneShadow) where the scene says.
  template <bool kPadded, class Leaf, class Step>
  static M any_one_ray(const Prepared& s, const M& valid, const V& p, const V& l, const B& dist,
                       RayCounts& counts, Leaf& leaf, Step& step) noexcept {
    OneShadow<kPadded, Step> one{s, p, l, dist, step, counts, s.walk.shadow_one_ray_lanes, {}, {}};
    return Tr::template any<kPadded>(s.bvh, valid, p, l, dist, leaf, one);
  }
};

}  // namespace lancer::packet
