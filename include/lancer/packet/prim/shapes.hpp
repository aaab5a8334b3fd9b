// Triangles, meshes and cylinders, a primitive module of the packets. Their own hierarchy
// (lancer/shapes.hpp: a binary SAH tree over every triangle and cylinder, collapsed into 4-wide
// nodes) is walked by the whole packet after the planes, as their ids come after the planes'
// (packet/prim/shapes_walk.hpp; coherent packets test a node's children against their frustum
// first, packet/prim/shapes_frustum.hpp). The tests are the reference's formula helpers
// (prim/triangle.hpp, prim/cylinder.hpp) on batches: the triangle test shears each lane by its
// own axes, picked per lane (or once for all, where every lane has the same), so every lane gets
// the reference's bits.
//
// Hit ids: a lane that hits a shape carries first_id + its primitive number (primitives are
// numbered in object-id order, so comparing these ids orders hits as object ids do, and ties
// within a mesh go to the lower primitive, as in the reference). object_of() turns them into
// object ids before anything reads a material or leaves the kernels.
//
// The walk's box test is conservative: it never turns away a box the reference's (double,
// padded) test accepts, so the closest hit, the least (t, primitive), does not depend on it.
// Include only from code built for the batch's ISA (packet/kernel.hpp).
#pragma once

#include <algorithm>
#include <cstdint>
#include <limits>
#include <new>
#include <vector>

#include "lancer/packet/lane_traits.hpp"
#include "lancer/packet/prim/shapes_frustum.hpp"
#include "lancer/packet/prim/shapes_lone.hpp"
#include "lancer/packet/prim/shapes_walk.hpp"
#include "lancer/prim/cylinder.hpp"
#include "lancer/prim/triangle.hpp"
#include "lancer/shapes.hpp"

namespace lancer::packet {

template <class Arch, class Real, class Mode>
struct ShapePackets : Lanes<Arch, Real, Mode> {
  using L = Lanes<Arch, Real, Mode>;
  using L::bits;
  using L::kProfile;
  using L::kTileH;
  using L::kTileW;
  using L::select3;
  using L::tests;
  using L::to_m;
  using L::to_mi;
  using L::W;
  using typename L::B;
  using typename L::I;
  using typename L::Id;
  using typename L::M;
  using typename L::MI;
  using typename L::Mth;
  using typename L::Prepared;
  using typename L::T;
  using typename L::V;
  using Shapes = PreparedShapes<T>;

  // Expected false: the branches on it are laid out for the scenes without shapes.
  static bool present(const Prepared& s) noexcept {
    return __builtin_expect(s.features.shapes, false);
  }
  // Shape ids start after the planes'.
  static int first_id(const Prepared& s) noexcept { return s.num_spheres + s.num_planes; }

  using Walk = ShapeWalk<Arch, T>;
  using Ray = typename Walk::Ray;

  using Leaf = typename Shapes::Leaf;
  // The nearest hit of leaf l's item k (its reference `ref`: a triangle >= 0, a sphere
  // kSphereRef, else ~cylinder) beyond eps for the lanes of `at`, infinity where none.
  static B prim_t(const Shapes& sh, const Leaf& l, unsigned k, std::int32_t ref, const Ray& r,
                  const M& at, const B& eps) noexcept {
    if (ref >= 0) return Walk::triangle_t(&l.v[0][k], r, at, eps);
    if (ref == Shapes::kSphereRef) return sphere_t(l, k, r, at, eps);
    const std::size_t c = std::size_t(~ref);
    const Vec3<T>& a = sh.cyl_base[c];
    const Vec3<T>& ax = sh.cyl_axis[c];
    return prim::cylinder_closest(r.o - V{B(a.x), B(a.y), B(a.z)}, r.d,
                                  V{B(ax.x), B(ax.y), B(ax.z)}, B(sh.cyl_h[c]), B(sh.cyl_r2[c]),
                                  sh.cyl_caps[c] != 0, eps)
        .t;
  }

  // Leaf l's item k, a sphere (its centre and squared radius in rows 0 to 3): its nearest hit
  // beyond eps for the lanes of `at`, infinity where none: the reference's formulas
  // (formulas.hpp), as the spheres' own module computes them.
  [[gnu::noinline]] static B sphere_t(const Leaf& l, unsigned k, const Ray& r, const M& at,
                                      const B& eps) noexcept {
    const B inf(std::numeric_limits<T>::infinity());
    const B r2(l.v[3][k]);
    const V f = r.o - V{B(l.v[0][k]), B(l.v[1][k]), B(l.v[2][k])};
    const SphereDisc<B> sd = sphere_disc<Mth>(f, r.d, r2);
    const M m = at & (sd.disc >= B(T(0)));
    if (!xsimd::any(m)) return inf;
    const B t = sphere_first_root(sphere_roots<Mth>(sd, sphere_c<Mth>(f, r2)), eps);
    return xsimd::select(m & (t > eps), t, inf);
  }

  // A hit t (hit id pid, never negative) kept where it is nearer for the lanes of `at`: a nearer
  // t wins, an equal t only over a hit of a higher id (the reference's order; -1, none, is lower
  // than every hit id, so a miss at t == best_t never takes it).
  [[gnu::always_inline]] static void keep_nearer(const B& t, const I& pid, const M& at, B& best_t,
                                                 I& best_id) noexcept {
    const M tie = (t == best_t) & to_m(pid < best_id);
    const M take = at & ((t < best_t) | tie);
    best_t = xsimd::select(take, t, best_t);
    best_id = xsimd::select(to_mi(take), pid, best_id);
  }

  // Visits the leaves of the shapes' wide hierarchy that some lane of `lanes` may reach before
  // limit(): leaf(leaf index, count, lanes_at_leaf) returns true to stop.
  template <class Limit, class Leaf>
  [[gnu::always_inline]] static void walk(const Shapes& sh, const Ray& r, const M& lanes,
                                          Limit&& limit, Leaf&& leaf) noexcept {
    if (sh.wide.empty()) return;
    Walk::with_box_test(r, [&](auto test) {
      Walk::template walk<decltype(test)::value>(sh, r, lanes, limit, leaf);
    });
  }

  // A coherent packet's walk: the frustum first (packet/prim/shapes_frustum.hpp) on hierarchies
  // of kFrustumFrom primitives or more; on smaller ones, whose walks enter few nodes, the
  // frustum's own test costs more than it saves (primary rays on meshes of 1k and 16k
  // triangles and on the cylinders scene ran 5% to 15% slower with it, the bunny and meshes of
  // 64k and 1M triangles 5% to 50% faster).
  static constexpr std::size_t kFrustumFrom = 32768;
  template <class Limit, class Leaf>
  [[gnu::always_inline]] static void coherent_walk(const Shapes& sh, const Ray& r, const M& lanes,
                                                   Limit& limit, Leaf& leaf) noexcept {
    if (sh.items() >= kFrustumFrom)
      ShapeFrustum<Arch, T>::walk(sh, r, lanes, limit, leaf);
    else
      walk(sh, r, lanes, limit, leaf);
  }
  // Closest hit over the shapes for the lanes of `valid`: a nearer t wins, an equal t only
  // over another shape of a higher primitive number (the reference's order). The walk is out of
  // line, by value: inlined, it changed the code GCC made for scenes without shapes (course
  // scenes ran 3% to 5% more instructions, callgrind).
  [[gnu::always_inline]] static void closest(const Prepared& s, const M& valid, const V& o,
                                             const V& d, B& best_t, I& best_id,
                                             RayCounts& counts) noexcept {
    const Found f = closest_walk(s, valid, o, d, best_t, best_id, counts);
    best_t = f.t, best_id = f.id;
  }
  struct Found {
    B t;
    I id;
  };
  [[gnu::noinline]] static Found closest_walk(const Prepared& s, M valid, V o, V d, B best_t,
                                              I best_id, RayCounts& counts) noexcept {
    const Shapes& sh = *s.shapes;
    const Ray r(o, d, valid);
    const B eps(s.epsilon);
    const Id first = Id(first_id(s));
    auto limit = [&] { return best_t; };
    auto leaf = [&](std::uint32_t index, std::uint32_t n, const M& at) {
      const Leaf& l = sh.leaves[index];
      for (unsigned k = 0; k < n; ++k) {
        const std::int32_t ref = l.ref[k];
        tests(counts, at, ref == Shapes::kSphereRef);
        const B t = prim_t(sh, l, k, ref, r, at, eps);
        const I pid(Id(first + Id(l.prim[k])));
        keep_nearer(t, pid, at, best_t, best_id);
      }
      return false;
    };
    if (coherent(r, valid, kLoneClosest)) {
      coherent_walk(sh, r, valid, limit, leaf);
      return {best_t, best_id};
    }
    LoneRays rays(r);
    auto alone = [&](std::uint32_t child, unsigned count, const M& at) {
      alignas(64) T bt[W];
      alignas(64) Id bi[W];
      best_t.store_aligned(bt);
      best_id.store_aligned(bi);
      for (unsigned lanes = bits(at); lanes; lanes &= lanes - 1) {
        const int k = __builtin_ctz(lanes);
        std::int64_t id = bi[k];
        if (Lone::closest(sh, rays.lane(k), s.epsilon, first, bt[k], id, std::int32_t(child),
                          count))
          bi[k] = Id(id);
      }
      best_t = B::load_aligned(bt), best_id = I::load_aligned(bi);
      return false;
    };
    hybrid(sh, r, valid, limit, leaf, alone, kLoneClosest);
    return {best_t, best_id};
  }

  // Closest hits of a camera block's kGX x kGY tiles (tile g at column g % kGX, row g / kGX),
  // as closest() finds them tile by tile: groups of 8 tiles (4 x 2 where the block is 4 or
  // more tiles wide) walk the hierarchy together (ShapeFrustum::walk_group), sharing its
  // nodes' loads and frustum tests, as far as their rays share direction signs (a group
  // across an axis of the view walks once per side). Groups of 4 and 16 tiles were slower on
  // the bunny and no faster on a mesh of a million triangles (width 16).
  static constexpr bool kBlocks = true;
  template <int kGX, int kGY>
  [[gnu::noinline]] static void closest_group(const Prepared& s, const M* valid, const V* o,
                                              const V* d, B* best_t, I* best_id,
                                              RayCounts& counts) noexcept {
    constexpr int kSX = kGX < 4 ? kGX : 4, kSY = 8 / kSX < kGY ? 8 / kSX : kGY, kS = kSX * kSY;
    static_assert(kGX % kSX == 0 && kGY % kSY == 0, "the block is whole groups");
    if constexpr (kProfile)
      counts.profile->shape_groups.group_w = kTileW * kSX,
      counts.profile->shape_groups.group_h = kTileH * kSY;
    const auto count_to = group_count(counts);
    for (int y0 = 0; y0 < kGY; y0 += kSY)
      for (int x0 = 0; x0 < kGX; x0 += kSX) {
        int g[kS];
        for (int k = 0; k < kS; ++k) g[k] = (y0 + k / kSX) * kGX + x0 + k % kSX;
        closest_square<kS>(s, g, valid, o, d, best_t, best_id, counts, count_to);
      }
  }
  template <int kS, class Count>
  [[gnu::always_inline]] static void closest_square(const Prepared& s, const int* g, const M* valid,
                                                    const V* o, const V* d, B* best_t, I* best_id,
                                                    RayCounts& counts, Count count_to) noexcept {
    using Frustum = ShapeFrustum<Arch, T>;
    const Shapes& sh = *s.shapes;
    alignas(Ray) unsigned char raw[kS * sizeof(Ray)];
    Ray* r = reinterpret_cast<Ray*>(raw);
    unsigned live = 0;
    M lanes[kS];
    B bt[kS];
    I bi[kS];
    for (int k = 0; k < kS; ++k) {
      if (!xsimd::any(valid[g[k]])) continue;
      live |= 1u << k;
      new (r + k) Ray(o[g[k]], d[g[k]], valid[g[k]]);
      lanes[k] = valid[g[k]], bt[k] = best_t[g[k]], bi[k] = best_id[g[k]];
    }
    count_to.group(live);
    const B eps(s.epsilon);
    const Id first = Id(first_id(s));
    auto limit = [&](int i) { return bt[i]; };
    auto leaf = [&](std::uint32_t index, std::uint32_t n, const M* at, unsigned packets) {
      count_to.leaf(at, packets);
      const Leaf& l = sh.leaves[index];
      for (unsigned k = 0; k < n; ++k) {
        const std::int32_t ref = l.ref[k];
        const I pid(Id(first + Id(l.prim[k])));
        for (unsigned q = packets; q; q &= q - 1) {
          const int i = __builtin_ctz(q);
          tests(counts, at[i], ref == Shapes::kSphereRef);
          const B t = prim_t(sh, l, k, ref, r[i], at[i], eps);
          keep_nearer(t, pid, at[i], bt[i], bi[i]);
        }
      }
      return false;
    };
    // The group's packets by direction signs (a group on the image's centre lines holds two or
    // four such sets), each set walking together; packets of mixed signs tile by tile.
    for (unsigned rest = live; rest;) {
      const unsigned set = Frustum::same_signs(r, rest);
      if (set == 0) {
        count_to.tiles_alone(rest);
        for (unsigned p = rest; p; p &= p - 1) {
          const int k = g[__builtin_ctz(p)];
          closest(s, valid[k], o[k], d[k], bt[__builtin_ctz(p)], bi[__builtin_ctz(p)], counts);
        }
        break;
      }
      count_to.walk();
      Frustum::template walk_group<kS>(sh, r, lanes, set, limit, leaf, count_to);
      rest &= ~set;
    }
    for (unsigned p = live; p; p &= p - 1) {
      const int k = __builtin_ctz(p);
      best_t[g[k]] = bt[k], best_id[g[k]] = bi[k];
    }
  }

  // The camera groups counted into the profile (ProfiledMode only; elsewhere NoGroupCount).
  struct GroupCount {
    StageProfile::ShapeGroups* g;
    void group(unsigned live) const noexcept { g->groups += live != 0; }
    void walk() const noexcept { ++g->walks; }
    void tiles_alone(unsigned tiles) const noexcept {
      g->tiles_alone += unsigned(__builtin_popcount(tiles));
    }
    void node() const noexcept { ++g->nodes; }
    void box_test() const noexcept { ++g->box_tests; }
    void leaf(const M* at, unsigned packets) const noexcept {
      ++g->leaves;
      for (unsigned q = packets; q; q &= q - 1)
        ++g->leaf_calls, g->leaf_lanes += unsigned(__builtin_popcount(bits(at[__builtin_ctz(q)])));
    }
  };
  static auto group_count(RayCounts& counts) noexcept {
    if constexpr (kProfile)
      return GroupCount{&counts.profile->shape_groups};
    else
      return NoGroupCount<M>{};
  }

  // The live lanes at or below which a subtree's lanes go on alone (closest hit, opaque any
  // hit), tuned on incoherent rays over a mesh (bench's diffuse and ao sets), widths 8 and 16.
  static constexpr int kLoneClosest = 2, kLoneAny = 2;
  // Whether the packet walks whole (the packet walk alone): more than `lone` live lanes, each
  // with the same shear axes and the same direction signs, as camera rays and a flat mirror's
  // have. Else the hybrid walk, lanes going on alone (ShapeLone) where few reach a subtree.
  static bool coherent(const Ray& r, const M& live, int lone) noexcept {
    return r.uniform && r.fast && __builtin_popcount(bits(live)) > lone;
  }
  using Lone = ShapeLone<Arch, T>;
  template <class Limit, class Leaf, class Alone>
  static void hybrid(const Shapes& sh, const Ray& r, const M& lanes, Limit& limit, Leaf& leaf,
                     Alone& alone, int lone) noexcept {
    if (sh.wide.empty()) return;
    Walk::with_box_test(r, [&](auto test) {
      Walk::template walk_lanes<decltype(test)::value, true>(sh, r, lanes, limit, leaf, alone,
                                                             lone);
    });
  }
  // A packet's rays lane by lane, each made ready for ShapeLone when it first goes alone.
  struct LoneRays {
    alignas(64) T o[3][W], d[3][W], f[6][W];  // f: the packet Ray's sx, sy, sz and 1 / d
    typename Lone::Ray ray[W];
    unsigned made = 0;
    unsigned axis[6];  // the lanes whose kx is 0, kx is 1, ky is 0, ..., kz is 1
    LoneRays(const Ray& r) noexcept
        : axis{bits(r.x0), bits(r.x1), bits(r.y0), bits(r.y1), bits(r.z0), bits(r.z1)} {
      r.o.x.store_aligned(o[0]), r.o.y.store_aligned(o[1]), r.o.z.store_aligned(o[2]);
      r.d.x.store_aligned(d[0]), r.d.y.store_aligned(d[1]), r.d.z.store_aligned(d[2]);
      r.sx.store_aligned(f[0]), r.sy.store_aligned(f[1]), r.sz.store_aligned(f[2]);
      r.inv.x.store_aligned(f[3]), r.inv.y.store_aligned(f[4]), r.inv.z.store_aligned(f[5]);
    }
    const typename Lone::Ray& lane(int k) noexcept {
      if (!(made >> k & 1u)) {
        const T ok[3] = {o[0][k], o[1][k], o[2][k]}, dk[3] = {d[0][k], d[1][k], d[2][k]};
        const T fk[6] = {f[0][k], f[1][k], f[2][k], f[3][k], f[4][k], f[5][k]};
        int ax[3];
        for (int a = 0; a < 3; ++a)
          ax[a] = (axis[2 * a] >> k & 1u) ? 0 : (axis[2 * a + 1] >> k & 1u) ? 1 : 2;
        ray[k] = typename Lone::Ray(ok, dk, ax, fk);
        made |= 1u << k;
      }
      return ray[k];
    }
  };

  // The object id of one hit id (unchanged below first_id).
  static std::int32_t object_of(const Prepared& s, std::int32_t hit_id) noexcept {
    const int first = first_id(s);
    if (hit_id < first) return hit_id;
    return s.shapes->prim_object(hit_id - first);
  }
  // The object ids of hit ids (unchanged below first_id), from the shapes' primitive ranges
  // (PreparedShapes::prim_object). Primitives are numbered in object-id order: where the lowest
  // and the highest shape hit of the lanes are on one object, every shape hit between is on it
  // too, and two searches serve the packet.
  [[gnu::noinline]] static I object_of(const Prepared& s, I hit_id) noexcept {
    const Shapes& sh = *s.shapes;
    const Id first = Id(first_id(s));
    if (!xsimd::any(hit_id >= I(first))) return hit_id;
    alignas(64) Id v[W];
    hit_id.store_aligned(v);
    Id lo = std::numeric_limits<Id>::max(), hi = first;
    for (int k = 0; k < W; ++k)
      if (v[k] >= first) lo = v[k] < lo ? v[k] : lo, hi = v[k] > hi ? v[k] : hi;
    const Id obj = Id(sh.prim_object(std::int32_t(lo - first)));
    if (lo == hi || obj == Id(sh.prim_object(std::int32_t(hi - first)))) {
      for (int k = 0; k < W; ++k)
        if (v[k] >= first) v[k] = obj;
      return I::load_aligned(v);
    }
    for (int k = 0; k < W; ++k)
      if (v[k] >= first) v[k] = Id(sh.prim_object(std::int32_t(v[k] - first)));
    return I::load_aligned(v);
  }

  // An object met by shadow segments and the lanes that meet it (met_objects()).
  struct Met {
    int object;
    unsigned lanes;
  };
  struct MetList {
    const Met* data;
    std::size_t n;
  };

  // Any hit over the shapes for the lanes still pending, from p along unit l before `dist`.
  // Opaque scenes (no transparency): every object blocks, and the callers' step (queries.hpp
  // shadow_hit, the API's occlusion) only clears its lanes, so the walk returns the lanes still
  // pending itself (blocked_walk: a lane is done at its first occluder, no object named).
  // Else step(object, lanes, pending) for each object the lanes meet beyond eps, each once per
  // lane, in ascending object id (the reference's order: a float product of three or more
  // transmittances depends on it). The walks are out of line, for the reason given at
  // closest().
  template <class Step>
  [[gnu::always_inline]] static M any(const Prepared& s, M pending, const V& p, const V& l,
                                      const B& dist, const B& eps, RayCounts& counts,
                                      Step& step) noexcept {
    if (!s.features.transparency) return blocked_walk(s, pending, p, l, dist, eps, counts);
    const MetList met = met_objects(s, pending, p, l, dist, eps, counts);
    std::size_t k = 0;
    return step_met(met, k, met.n, pending, step);
  }
  // any() in a scene with transparency whose spheres are leaves of this hierarchy: the spheres
  // met, then between(pending) (the kinds whose ids lie between the spheres' and the shapes'),
  // then the shapes met, so that every lane's objects come in ascending id.
  template <class Step, class Between>
  [[gnu::always_inline]] static M any_around(const Prepared& s, M pending, const V& p, const V& l,
                                             const B& dist, const B& eps, RayCounts& counts,
                                             Step& step, Between&& between) noexcept {
    const MetList met = met_objects(s, pending, p, l, dist, eps, counts);
    std::size_t k = 0, spheres = 0;
    while (spheres < met.n && met.data[spheres].object < s.num_spheres) ++spheres;
    pending = step_met(met, k, spheres, pending, step);
    if (xsimd::any(pending)) pending = between(pending);
    return step_met(met, k, met.n, pending, step);
  }
  // step() for the objects met[k .. end) while a lane is pending; k left where it stopped.
  template <class Step>
  [[gnu::always_inline]] static M step_met(const MetList& met, std::size_t& k, std::size_t end,
                                           M pending, Step& step) noexcept {
    for (; k < end && xsimd::any(pending); ++k) {
      const M m = pending & from_bits(met.data[k].lanes);
      if (xsimd::any(m)) pending = step(Id(met.data[k].object), m, pending);
    }
    return pending;
  }

  // The object of leaf l's item k (a sphere's is its hit id).
  static int leaf_object(const Shapes& sh, const Leaf& l, unsigned k) noexcept {
    return l.ref[k] == Shapes::kSphereRef ? sh.first_object + l.prim[k] : sh.prim_object(l.prim[k]);
  }

  // Leaf `index`'s first n items against the segments of the lanes of at & pending (pending
  // re-read at each item): on_hit(leaf, item, lanes) where some lane meets the item beyond eps
  // before `dist`; true from it stops.
  template <class OnHit>
  [[gnu::always_inline]] static bool segment_leaf(const Shapes& sh, const Ray& r,
                                                  std::uint32_t index, std::uint32_t n, const M& at,
                                                  const M& pending, const B& dist, const B& eps,
                                                  RayCounts& counts, OnHit&& on_hit) noexcept {
    const Leaf& l = sh.leaves[index];
    for (unsigned k = 0; k < n; ++k) {
      const M lanes = at & pending;
      tests(counts, lanes, l.ref[k] == Shapes::kSphereRef);
      const M hit = lanes & (prim_t(sh, l, k, l.ref[k], r, lanes, eps) < dist);
      if (xsimd::any(hit) && on_hit(l, k, hit)) return true;
    }
    return false;
  }

  // The lanes of `pending` whose segments meet no shape beyond eps before `dist`: the packet
  // walk, or the hybrid one where the lanes diverge (a lane alone stops at its first occluder).
  [[gnu::noinline]] static M blocked_walk(const Prepared& s, M pending, V p, V l, B dist, B eps,
                                          RayCounts& counts) noexcept {
    const Shapes& sh = *s.shapes;
    const Ray r(p, l, pending);
    auto limit = [&] { return dist; };
    auto leaf = [&](std::uint32_t index, std::uint32_t n, const M& at) {
      return segment_leaf(sh, r, index, n, at, pending, dist, eps, counts,
                          [&](const Leaf&, unsigned, const M& hit) {
                            pending = pending & ~hit;
                            return !xsimd::any(pending);
                          });
    };
    if (coherent(r, pending, kLoneAny)) {
      coherent_walk(sh, r, pending, limit, leaf);
      return pending;
    }
    LoneRays rays(r);
    alignas(64) T dd[W];
    dist.store_aligned(dd);
    auto alone = [&](std::uint32_t child, unsigned count, const M& at) {
      unsigned blocked = 0;
      for (unsigned lanes = bits(at & pending); lanes; lanes &= lanes - 1) {
        const int k = __builtin_ctz(lanes);
        if (Lone::any(sh, rays.lane(k), s.epsilon, dd[k], std::int32_t(child), count))
          blocked |= 1u << k;
      }
      if (blocked == 0) return false;
      pending = pending & ~from_bits(blocked);
      return !xsimd::any(pending);
    };
    hybrid(sh, r, pending, limit, leaf, alone, kLoneAny);
    return pending;
  }

  // The objects a packet of shadow segments meets in a scene with transparency, each with the
  // lanes that meet it, in ascending object id. The list lives in a buffer of the thread's,
  // valid until its next call.
  [[gnu::noinline]] static MetList met_objects(const Prepared& s, M pending, V p, V l, B dist,
                                               B eps, RayCounts& counts) noexcept {
    const Shapes& sh = *s.shapes;
    const Ray r(p, l, pending);
    thread_local std::vector<Met> met;
    met.clear();
    auto add = [&](int obj, unsigned lanes) {
      auto it = std::find_if(met.begin(), met.end(), [&](const Met& m) { return m.object == obj; });
      if (it == met.end()) it = met.insert(met.end(), Met{obj, 0u});
      it->lanes |= lanes;
    };
    auto limit = [&] { return dist; };
    auto leaf = [&](std::uint32_t index, std::uint32_t n, const M& at) {
      return segment_leaf(sh, r, index, n, at, pending, dist, eps, counts,
                          [&](const Leaf& at_leaf, unsigned k, const M& hit) {
                            add(leaf_object(sh, at_leaf, k), bits(hit));
                            return false;
                          });
    };
    walk(sh, r, pending, limit, leaf);
    std::sort(met.begin(), met.end(),
              [](const Met& a, const Met& b) { return a.object < b.object; });
    return {met.data(), met.size()};
  }

  // The primitives the lanes of `hit` hit (a shape's hit id), lane by lane: triangles' vertices
  // and cylinders' parameters, for the normals below.
  struct Hits {
    M tri, cyl;  // lanes on a triangle, on a cylinder
    bool any_cyl = false, any_smooth = false;
    V v0, v1, v2;   // triangles
    V n0, n1, n2;   // smooth triangles' vertex normals (else 0)
    M smooth;       // lanes on a smooth triangle
    V base, axis;   // cylinders
    B h, r2, caps;  // caps: 1 where the cylinder has them
  };
  static Hits hits_of(const Prepared& s, const M& hit, const I& best_id) noexcept {
    const Shapes& sh = *s.shapes;
    const Id first = Id(first_id(s));
    alignas(64) Id id[W];
    best_id.store_aligned(id);
    const unsigned lanes = bits(hit & to_m(best_id >= I(first)));
    alignas(64) T f[18][W] = {};
    alignas(64) Id kind[W] = {}, smooth[W] = {};
    Hits h;
    for (int k = 0; k < W; ++k) {
      if (!((lanes >> k) & 1u)) continue;
      const std::int32_t ref = sh.prim[std::size_t(id[k] - first)];
      if (ref < 0) {
        const std::size_t c = std::size_t(~ref);
        kind[k] = 2, h.any_cyl = true;
        const Vec3<T>& a = sh.cyl_base[c];
        const Vec3<T>& x = sh.cyl_axis[c];
        const T v[9] = {a.x,         a.y,          a.z,
                        x.x,         x.y,          x.z,
                        sh.cyl_h[c], sh.cyl_r2[c], T(sh.cyl_caps[c] != 0 ? 1 : 0)};
        for (int q = 0; q < 9; ++q) f[q][k] = v[q];
        continue;
      }
      kind[k] = 1;
      const std::size_t t = std::size_t(ref);
      for (int c = 0; c < 3; ++c) {
        const std::uint32_t v = sh.tri[3 * t + std::size_t(c)];
        f[9 + 3 * c][k] = sh.vx[v], f[10 + 3 * c][k] = sh.vy[v], f[11 + 3 * c][k] = sh.vz[v];
      }
      if (sh.tri_normals.empty() || sh.tri_normals[3 * t] == Shapes::kNoNormal) continue;
      smooth[k] = 1, h.any_smooth = true;
    }
    auto load = [&](int q) { return B::load_aligned(f[q]); };
    auto load3 = [&](int q) { return V{load(q), load(q + 1), load(q + 2)}; };
    h.base = load3(0), h.axis = load3(3), h.h = load(6), h.r2 = load(7), h.caps = load(8);
    h.v0 = load3(9), h.v1 = load3(12), h.v2 = load3(15);
    const I kinds = I::load_aligned(kind);
    h.tri = to_m(kinds == I(Id(1))), h.cyl = to_m(kinds == I(Id(2)));
    h.smooth = to_m(I::load_aligned(smooth) != I(Id(0)));
    if (h.any_smooth) {
      alignas(64) T nv[9][W] = {};
      for (int k = 0; k < W; ++k) {
        if (!smooth[k]) continue;
        const std::size_t t = std::size_t(sh.prim[std::size_t(id[k] - first)]);
        for (int c = 0; c < 3; ++c) {
          const std::uint32_t v = sh.tri_normals[3 * t + std::size_t(c)];
          nv[3 * c][k] = sh.nx[v], nv[3 * c + 1][k] = sh.ny[v], nv[3 * c + 2][k] = sh.nz[v];
        }
      }
      auto n3 = [&](int q) {
        return V{B::load_aligned(nv[q]), B::load_aligned(nv[q + 1]), B::load_aligned(nv[q + 2])};
      };
      h.n0 = n3(0), h.n1 = n3(3), h.n2 = n3(6);
    }
    return h;
  }

  // The geometric normal at the lanes of `hit` on a shape (prim::triangle_normal,
  // prim::cylinder_normal, as the reference's shapes_normals); smooth meshes' shading normal is
  // shading_normal()'s. The last kind in id order: it overwrites its lanes of n.
  [[gnu::always_inline]] static void surface(const Prepared& s, const M& hit, const I& best_id,
                                             const I& id, const V& o, const V& d, const B& best_t,
                                             const B& magnitude, V& p, V& n, B& delta) noexcept {
    (void)id, (void)best_t, (void)magnitude, (void)delta;
    const M mine = hit & to_m(best_id >= I(Id(first_id(s))));
    if (!xsimd::any(mine)) return;
    n = select3(mine, geometric_normal(s, mine, best_id, o, d, p), n);
  }
  [[gnu::noinline]] static V geometric_normal(const Prepared& s, M mine, I best_id, V o, V d,
                                              V p) noexcept {
    const Hits h = hits_of(s, mine, best_id);
    V g = prim::triangle_normal(h.v0, h.v1, h.v2);
    if (h.any_cyl) {
      const B eps(s.epsilon);
      const V f = o - h.base;
      const B part_caps = prim::cylinder_closest(f, d, h.axis, h.h, h.r2, true, eps).part;
      const B part_open = prim::cylinder_closest(f, d, h.axis, h.h, h.r2, false, eps).part;
      const B part = xsimd::select(h.caps != B(T(0)), part_caps, part_open);
      g = select3(h.cyl, prim::cylinder_normal(p, h.base, h.axis, part), g);
    }
    return g;
  }

  // Whether any mesh is smooth: shading then takes shading_normal() for its lighting.
  static bool smooth(const Prepared& s) noexcept {
    return __builtin_expect(s.features.shapes && !s.shapes->tri_normals.empty(), false);
  }
  // The shading normal at the lanes of `hit` (not turned to the ray): a smooth triangle's blend
  // of its vertex normals at the hit's barycentrics (prim::smooth_normal), else `geometric`.
  static V shading_normal(const Prepared& s, const M& hit, const I& best_id, const V& o, const V& d,
                          const V& geometric) noexcept {
    const M mine = hit & to_m(best_id >= I(Id(first_id(s))));
    if (!xsimd::any(mine)) return geometric;
    const Hits h = hits_of(s, mine, best_id);
    if (!h.any_smooth) return geometric;
    const Ray r(o, d, h.smooth);
    const prim::TriangleEdges<B> e = prim::triangle_edges<T>(
        r.permuted(h.v0 - o), r.permuted(h.v1 - o), r.permuted(h.v2 - o), r.sx, r.sy, r.sz);
    const V blend =
        prim::smooth_normal(prim::triangle_barycentrics(e), h.n0, h.n1, h.n2, geometric);
    return select3(h.smooth, blend, geometric);
  }

  static M from_bits(unsigned b) noexcept {
    alignas(64) Id v[W];
    for (int k = 0; k < W; ++k) v[k] = (b >> k) & 1u ? Id(1) : Id(0);
    return to_m(I::load_aligned(v) != I(Id(0)));
  }
};

}  // namespace lancer::packet
