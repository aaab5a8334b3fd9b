// One ray alone over the shapes' hierarchy, for a packet's lanes that do not stay together
// (secondary rays: diffuse bounces, ambient occlusion) and for the one-ray kernels: the packet
// walk (shapes_walk.hpp) tests one primitive at a time across every lane, and where the lanes
// diverge most of that work is for lanes that left the subtree long ago.
//
// The walk runs over the lone nodes (PreparedShapes::lone: the tree collapsed from the root into
// nodes of eight children); a lane handed over at a wide node starts at that node's entry
// (PreparedShapes::lone_entry), the slots under it of a lone node. A node's eight children
// are tested at once, in one register of eight floats (AVX; else two of four, and doubles two or
// four at a time), by the packet walk's own conservative slab form with the ray's values in
// every lane, so a box it turns away the packet walk turns away too (shapes_walk.hpp's header
// gives the margins). The closest hit takes met children nearest entry first; occlusion takes
// them in slot order (Embree's any-hit walk); popped subtrees beyond the limit are culled. A
// leaf's triangles are tested several at a time, the triangles across the register's lanes, by
// the reference's watertight formula (prim/triangle.hpp on batches; one ray has one shear
// permutation, so picking the vertices' components is a scalar choice) and the same operations
// in the same order, so each lane computes the reference's bits. Cylinders and spheres are
// tested by the reference's scalar formulas.
// The closest hit is the least (t, primitive), so the order of the tests changes nothing.
// Include only from code built for the batch's ISA (packet/kernel.hpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <xsimd/xsimd.hpp>

#include "lancer/formulas.hpp"
#include "lancer/packet/fused.hpp"
#include "lancer/packet/lanes.hpp"
#include "lancer/prim/cylinder.hpp"
#include "lancer/prim/triangle.hpp"
#include "lancer/shapes.hpp"

namespace lancer::packet {

// The register of four T, or of two doubles where no 256-bit one is there. Templated on the
// kernels' Arch, as everything built per ISA is: each ISA's unit has its own instantiations.
template <class Arch, class T>
struct LoneArch {
#if defined(__aarch64__)
  using type = xsimd::neon64;
#elif defined(__AVX__)
  using type = std::conditional_t<sizeof(T) == 8, xsimd::avx, xsimd::sse4_2>;
#else
  using type = xsimd::sse4_2;
#endif
};

// The register of a lone node's boxes: eight floats or four doubles where AVX is there.
template <class Arch, class T>
struct LoneNodeArch {
#if defined(__aarch64__)
  using type = xsimd::neon64;
#elif defined(__AVX__)
  using type = xsimd::avx;
#else
  using type = xsimd::sse4_2;
#endif
};

template <class Arch, class T>
struct ShapeLone {
  using Shapes = PreparedShapes<T>;
  using Node = typename Shapes::LoneNode;
  using C = xsimd::batch<T, typename LoneArch<Arch, T>::type>;  // a leaf's triangles
  using CM = xsimd::batch_bool<T, typename LoneArch<Arch, T>::type>;
  using CV = Vec3<C>;
  using N = xsimd::batch<T, typename LoneNodeArch<Arch, T>::type>;  // a node's boxes
  using NM = xsimd::batch_bool<T, typename LoneNodeArch<Arch, T>::type>;
  static constexpr int kC = static_cast<int>(C::size);
  static constexpr int kN = static_cast<int>(N::size);
  static constexpr int kL = Shapes::kLone;
  static constexpr int kParts = kL / kN;  // registers per node's children
  static constexpr T kWiden = sizeof(T) == 4 ? T(0x1p-20) : T(0x1p-49);
  static_assert(kL % kN == 0);

  // One ray as the tests see it: the reference's shear, and the packet walk's slab form.
  struct Ray {
    T o[3], d[3];
    prim::RayShear<T> shear;
    T o_perm[3];                   // o in the shear's axis order
    T inv[3];                      // 1 / d, 1 where d is 0
    T o_pad, o_near[3], o_far[3];  // o_near: o + o_pad where d goes up, o - o_pad where down
    T oi_near[3], oi_far[3];       // o_near / d, o_far / d (as o_near inv): the slabs' offsets
    int near[3], far[3];  // offsets (in T) in a LoneNode of each axis' entry and exit planes
    bool fast = true;     // every |d| at least 2^-60: entry and exit planes known per axis

    Ray() = default;
    // A packet's lane, its shear and quotients as the packet's Ray (shapes_walk.hpp) computed
    // them, by ray_shear's comparisons and the same divisions: axes kx, ky, kz; f = sx, sy, sz,
    // then 1 / d per axis (1 where 0).
    Ray(const T* org, const T* dir, const int* axes, const T* f) noexcept
        : Ray(org, dir, {axes[0], axes[1], axes[2], f[0], f[1], f[2]}, f[3], f[4], f[5]) {}
    // One ray on its own (the one-ray kernels): ray_shear's shear and 1 / d (1 where 0).
    Ray(const T* org, const T* dir) noexcept
        : Ray(org, dir, prim::ray_shear(Vec3<T>{dir[0], dir[1], dir[2]}), quotient(dir[0]),
              quotient(dir[1]), quotient(dir[2])) {}
    // Every field from scalars, written once each: a copy of arrays written a float at a time
    // by wider moves would wait on store-to-load forwarding, which fails there.
    Ray(const T* org, const T* dir, const prim::RayShear<T>& sh, T i0, T i1, T i2) noexcept
        : o{org[0], org[1], org[2]}, d{dir[0], dir[1], dir[2]}, shear(sh), inv{i0, i1, i2} {
      o_perm[0] = o[sh.kx], o_perm[1] = o[sh.ky], o_perm[2] = o[sh.kz];
      o_pad = T(Shapes::kWidePad) * std::max({std::fabs(o[0]), std::fabs(o[1]), std::fabs(o[2])});
      // Each axis' entry and exit planes by arithmetic on the direction's sign, not by a
      // choice the compiler makes a branch of: random directions mispredict it half the time.
      for (int a = 0; a < 3; ++a) {
        const int down = d[a] < T(0);
        fast = fast & (std::fabs(d[a]) >= T(0x1p-60));
        near[a] = Shapes::lone_lo_plane(a) + kL * down;
        far[a] = Shapes::lone_lo_plane(a) + kL * (1 - down);
        const T pad = down ? -o_pad : o_pad;
        o_near[a] = o[a] + pad, o_far[a] = o[a] - pad;
        oi_near[a] = o_near[a] * inv[a], oi_far[a] = o_far[a] * inv[a];
      }
    }
    static T quotient(T x) noexcept { return T(1) / (x == T(0) ? T(1) : x); }
  };

  // The children of n (slot bits) whose boxes [0, lim_w] may meet, and their entry t (widened):
  // shapes_walk.hpp's child_lanes with one ray in every lane and the children across lanes. Nd:
  // a lone node, or a wide node (walk() below says when).
  template <class Nd>
  static unsigned met_children(const Nd& n, const Ray& r, T lim_w, T* t0_out) noexcept {
    constexpr int kW = int(sizeof(n.child) / sizeof(n.child[0]));
    // A node's boxes in registers of eight (lone nodes, AVX) or four.
    using R = std::conditional_t<kW % kN == 0, N, C>;
    using RM = std::conditional_t<kW % kN == 0, NM, CM>;
    constexpr int kR = int(R::size), kRegs = kW / kR;
    static_assert(kW % kR == 0);
    // Plane offsets scale with the node's width (lo: 2 kW a, hi: 2 kW a + kW).
    auto at = [](int lone_offset) { return lone_offset * kW / kL; };
    unsigned met = 0;
    const T* base = &n.lo_x[0];
    for (int h = 0; h < kRegs; ++h) {
      auto plane = [&](int off) { return R::load_aligned(base + at(off) + h * kR); };
      R t0;
      RM in;
      if (r.fast) {
        // plane inv - o inv, fused where the ISA can (one operation on the walk's path).
        auto slab = [&](int off, T oi, T inv) { return slab_fmsub(plane(off), R(inv), R(oi)); };
        const R nx = slab(r.near[0], r.oi_near[0], r.inv[0]);
        const R fx = slab(r.far[0], r.oi_far[0], r.inv[0]);
        const R ny = slab(r.near[1], r.oi_near[1], r.inv[1]);
        const R fy = slab(r.far[1], r.oi_far[1], r.inv[1]);
        const R nz = slab(r.near[2], r.oi_near[2], r.inv[2]);
        const R fz = slab(r.far[2], r.oi_far[2], r.inv[2]);
        t0 = xsimd::max(xsimd::max(nx, ny), xsimd::max(nz, R(T(0)))) * R(T(1) - kWiden);
        const R t1 = xsimd::min(xsimd::min(fx, fy), fz) * R(T(1) + kWiden);
        in = t0 <= xsimd::min(t1, R(lim_w));
      } else {
        R near(T(0)), far(lim_w);
        RM out(false);
        for (int a = 0; a < 3; ++a) {
          const R lo_t = plane(Shapes::lone_lo_plane(a)), hi_t = plane(Shapes::lone_hi_plane(a));
          if (r.d[a] == T(0)) {
            const R lo = lo_t - R(r.o_pad), hi = hi_t + R(r.o_pad);
            out = out | (R(r.o[a]) < lo) | (R(r.o[a]) > hi);
            continue;
          }
          const R ea = (lo_t - R(r.o[a] + r.o_pad)) * R(r.inv[a]);
          const R eb = (hi_t - R(r.o[a] - r.o_pad)) * R(r.inv[a]);
          near = xsimd::max(near, xsimd::min(ea, eb));
          far = xsimd::min(far, xsimd::max(ea, eb) * R(T(1) + kWiden));
        }
        t0 = near * R(T(1) - kWiden);
        in = ~out & (t0 <= far);
      }
      t0.store_aligned(t0_out + h * kR);
      met |= lane_bits(in) << (h * kR);
    }
    return met & ((1u << n.arity) - 1);
  }

  // Lone nodes beyond which a walk handed over below the root stays on the wide nodes (some
  // 8 MiB of float lone nodes, a mesh of about 400k triangles).
  static constexpr std::size_t kLoneHandOffNodes = std::size_t(1) << 15;

  // A node's lines (a wide or a lone one), or a leaf's, on their way before the walk reaches
  // them. Always inlined: the walk calls it for every child it pushes.
  [[gnu::always_inline]] static void prefetch(const Shapes& sh, bool wide, std::int32_t child,
                                              unsigned count) noexcept {
    const std::size_t i = std::size_t(child);
    if (count != 0)
      prefetch_lines(&sh.leaves[i], sizeof(sh.leaves[0]));
    else if (wide)
      prefetch_lines(&sh.wide[i], sizeof(sh.wide[0]));
    else
      prefetch_lines(&sh.lone[i], sizeof(Node));
  }

  // The slots whose entry distance (d: a node's kL of them, in registers) lies beyond t, or at t
  // in a slot of `after`: those a child entered at t goes before, nearest first.
  static unsigned behind(const N* d, T t, unsigned after) noexcept {
    unsigned bits = 0;
    for (int h = 0; h < kParts; ++h) {
      const unsigned beyond = lane_bits(d[h] > N(t)), at = lane_bits(d[h] == N(t));
      bits |= (beyond | (at & (after >> (h * kN)))) << (h * kN);
    }
    return bits;
  }

  // Visits the leaves whose boxes the ray may meet before limit() (re-read after each leaf),
  // from wide node `child` (count 0) or the leaf `child` (count items): leaf(the leaf) returns
  // true to stop. kNear: met children nearest entry first (closest hit); else in slot order.
  template <bool kNear, class Limit, class Leaf>
  static void walk(const Shapes& sh, const Ray& r, Limit&& limit, Leaf&& leaf,
                   std::int32_t child = 0, unsigned count = 0) noexcept {
    if (sh.lone.empty()) return;
    std::int32_t st_child[Shapes::kLoneStack];
    std::uint8_t st_count[Shapes::kLoneStack];
    T st_t0[Shapes::kLoneStack];
    int sp = 0;
    const T widen = T(1) + kWiden;
    // Handed over below the root in a large hierarchy (more lone nodes than kLoneHandOffNodes),
    // the walk stays on the wide nodes: the packet walk has fetched the node it hands over, and
    // the lone nodes' four lines a node cost more than their fewer steps save once they come
    // from memory (docs/notebook/2026-11-incoherent-rays.md). Either kind walks the same
    // subtree.
    const bool wide = count == 0 && child != 0 && sh.lone.size() > kLoneHandOffNodes;
    // On the lone nodes, wide node `child`'s subtree: the slots under it of the lone node its
    // binary node starts or was opened into (PreparedShapes::lone_entry); every later node whole.
    unsigned slots = ~0u;
    if (count == 0 && !wide) {
      const typename Shapes::LoneEntry e = sh.lone_entry[std::size_t(child)];
      child = e.node, slots = e.slots;
    }
    // A node's entry distances; a wide node sets four, and the others, never met, stay 0.
    alignas(64) T t0[kL] = {};
    for (;;) {
      if (count == 0) {
        unsigned met;
        const std::int32_t* kids;
        const std::uint8_t* counts;
        if (wide) {
          const auto& n = sh.wide[std::size_t(child)];
          met = met_children(n, r, limit() * widen, t0), kids = n.child, counts = n.count;
        } else {
          const Node& n = sh.lone[std::size_t(child)];
          met = met_children(n, r, limit() * widen, t0) & slots, kids = n.child, counts = n.count;
          slots = ~0u;
        }
        if (met != 0) {
          // Pushed farthest first (kNear: each met child placed by its rank, no branch on the
          // distances), the nearest, on top, taken at once: from the node, not read back from
          // the stack just written (no store-to-load forwarding on the walk's path). A lone met
          // child is not pushed at all.
          const int c = __builtin_popcount(met);
          int top = __builtin_ctz(met);  // the nearest (kNear), else the first slot met
          if (c > 1) {
            [[maybe_unused]] N d[kParts];
            if constexpr (kNear)
              for (int h = 0; h < kParts; ++h) d[h] = N::load_aligned(t0 + h * kN);
            for (unsigned m = met; m; m &= m - 1) {
              const int k = __builtin_ctz(m);
              int at = sp;
              if constexpr (kNear) {
                // Below k: the met children farther than it, or as far in a higher slot (one
                // compare of the node's entries against k's, no branch on the distances).
                at = sp + __builtin_popcount(met & behind(d, t0[k], ~((2u << k) - 1u)));
                top = at == sp + c - 1 ? k : top;
              } else {
                at = sp + c - 1 - __builtin_popcount(met & ((1u << k) - 1u));
              }
              st_child[at] = kids[k], st_count[at] = counts[k], st_t0[at] = t0[k];
              prefetch(sh, wide, kids[k], counts[k]);
            }
            sp += c - 1;
          }
          child = kids[top], count = counts[top];
          continue;
        }
      } else if (leaf(sh.leaves[std::size_t(child)])) {
        return;
      }
      for (;;) {
        if (sp == 0) return;
        --sp;
        if (st_t0[sp] <= limit() * widen) {
          child = st_child[sp], count = st_count[sp];
          break;
        }
      }
    }
  }

  // Items [j, j + n) of leaf `l` (n <= kC, j a multiple of kC), triangles only in lanes: their
  // hits t beyond eps, in t_out. Returns the lanes hit (none past n or on a cylinder); tri_out:
  // the lanes of triangles.
  static unsigned triangles_t(const typename Shapes::Leaf& l, unsigned j, unsigned n, const Ray& r,
                              T eps, T* t_out, unsigned& tri_out) noexcept {
    const unsigned tri = (l.tri >> j) & ((1u << n) - 1u);
    tri_out = tri;
    if (tri == 0) return 0;
    const int perm[3] = {r.shear.kx, r.shear.ky, r.shear.kz};
    auto vertex = [&](int c) {
      CV p;
      C* out[3] = {&p.x, &p.y, &p.z};
      for (int a = 0; a < 3; ++a)
        *out[a] = C::load_aligned(&l.v[3 * c + perm[a]][j]) - C(r.o_perm[a]);
      return p;
    };
    const CV a = vertex(0), b = vertex(1), c = vertex(2);
    prim::TriangleEdges<C> e = prim::triangle_uvw<T>(a, b, c, C(r.shear.sx), C(r.shear.sy));
    const unsigned in = lane_bits(CM(prim::triangle_inside(e))) & tri;
    if (in == 0) return 0;
    prim::triangle_depth(e, a, b, c, C(r.shear.sz));
    const C t = prim::triangle_t(e);
    t.store_aligned(t_out);
    unsigned hit = 0;
    for (unsigned m = in; m; m &= m - 1) {
      const int k = __builtin_ctz(m);
      if (t_out[k] > eps) hit |= 1u << k;
    }
    return hit;
  }

  // The cylinder ~ref's nearest hit beyond eps (infinity where none): the reference's.
  static T cylinder_t(const Shapes& sh, std::int32_t ref, const Ray& r, T eps) noexcept {
    const std::size_t c = std::size_t(~ref);
    const Vec3<T> o{r.o[0], r.o[1], r.o[2]}, d{r.d[0], r.d[1], r.d[2]};
    return prim::cylinder_closest(o - sh.cyl_base[c], d, sh.cyl_axis[c], sh.cyl_h[c], sh.cyl_r2[c],
                                  sh.cyl_caps[c] != 0, eps)
        .t;
  }

  // The sphere of leaf l's item k (its centre and squared radius in rows 0 to 3): its nearest
  // hit beyond eps, infinity where none, by the reference's formulas.
  static T sphere_t(const typename Shapes::Leaf& l, unsigned k, const Ray& r, T eps) noexcept {
    const T inf = std::numeric_limits<T>::infinity();
    const Vec3<T> f{r.o[0] - l.v[0][k], r.o[1] - l.v[1][k], r.o[2] - l.v[2][k]};
    const Vec3<T> d{r.d[0], r.d[1], r.d[2]};
    const T r2 = l.v[3][k];
    const SphereDisc<T> sd = sphere_disc(f, d, r2);
    if (!(sd.disc >= T(0))) return inf;
    const T t = sphere_first_root(sphere_roots(sd, sphere_c(f, r2)), eps);
    return t > eps ? t : inf;
  }

  // Leaf l's items, kC at a time: hit(prim, t) for each triangle the ray meets beyond eps (prim
  // its record's, t its hit), then each cylinder and sphere of those kC (t its nearest hit
  // beyond eps, infinity where none); true from hit stops.
  template <class Hit>
  static bool leaf_hits(const Shapes& sh, const Ray& r, T eps, const typename Shapes::Leaf& l,
                        Hit&& hit) noexcept {
    static_assert(Shapes::kLeafItems % kC == 0);
    for (unsigned j = 0; j < l.count; j += unsigned(kC)) {
      const unsigned n = l.count - j < unsigned(kC) ? l.count - j : unsigned(kC);
      alignas(32) T t[kC];
      unsigned tri;
      for (unsigned m = triangles_t(l, j, n, r, eps, t, tri); m; m &= m - 1) {
        const unsigned k = unsigned(__builtin_ctz(m));
        if (hit(l.prim[j + k], t[k])) return true;
      }
      // The others: cylinders and spheres (none in a mesh's leaves).
      for (unsigned others = ~tri & ((1u << n) - 1u); others; others &= others - 1) {
        const unsigned k = unsigned(__builtin_ctz(others));
        const unsigned i = j + k;
        const std::int32_t ref = l.ref[i];
        const T tk =
            ref == Shapes::kSphereRef ? sphere_t(l, i, r, eps) : cylinder_t(sh, ref, r, eps);
        if (hit(l.prim[i], tk)) return true;
      }
    }
    return false;
  }

  // The closest hit over the hierarchy's items, from best_t / best_hit (a hit id: first_hit +
  // the leaf record's prim, -1 for none): a nearer t wins, an equal t only over a higher hit id.
  // Returns whether it changed.
  static bool closest(const Shapes& sh, const Ray& r, T eps, std::int64_t first_hit, T& best_t,
                      std::int64_t& best_hit, std::int32_t child = 0, unsigned count = 0) noexcept {
    bool changed = false;
    auto consider = [&](T t, std::int32_t prim) {
      const std::int64_t id = first_hit + std::int64_t(prim);
      if (t < best_t || (t == best_t && id < best_hit))  // id >= 0: never over -1
        best_t = t, best_hit = id, changed = true;
    };
    walk<true>(
        sh, r, [&] { return best_t; },
        [&](const typename Shapes::Leaf& l) {
          return leaf_hits(sh, r, eps, l, [&](std::int32_t prim, T t) {
            consider(t, prim);
            return false;
          });
        },
        child, count);
    return changed;
  }

  // Whether the segment meets a shape with eps < t < dist (the first one found: opaque scenes
  // need no other).
  static bool any(const Shapes& sh, const Ray& r, T eps, T dist, std::int32_t child = 0,
                  unsigned count = 0) noexcept {
    bool found = false;
    walk<false>(
        sh, r, [&] { return dist; },
        [&](const typename Shapes::Leaf& l) {
          return leaf_hits(sh, r, eps, l, [&](std::int32_t, T t) { return found = t < dist; });
        },
        child, count);
    return found;
  }
};

}  // namespace lancer::packet
