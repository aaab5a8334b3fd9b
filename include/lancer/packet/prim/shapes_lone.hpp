// One ray alone over the shapes' wide hierarchy (PreparedShapes::wide), for a packet's lanes that
// do not stay together (secondary rays: diffuse bounces, ambient occlusion): the packet walk
// (shapes_walk.hpp) tests one primitive at a time across every lane, and where the lanes diverge
// most of that work is for lanes that left the subtree long ago.
//
// A node's four children are tested at once, one register of four T (float: 128 bits; double:
// 256 where the ISA has AVX, else two registers of two), by the packet walk's own conservative
// slab form with the ray's values in every lane, so a box it turns away the packet walk turns
// away too (shapes_walk.hpp's header gives the margins). Children are taken nearest first by the
// ray's direction code; popped subtrees beyond the best t are culled. A leaf's triangles are
// tested several at a time, the triangles across the register's lanes, by the reference's
// watertight formula (prim/triangle.hpp on batches; one ray has one shear permutation, so picking
// the vertices' components is a scalar choice) and the same operations in the same order, so each
// lane computes the reference's bits. Cylinders and spheres are tested by the reference's scalar
// formulas.
// The closest hit is the least (t, primitive), so the order of the tests changes nothing.
// Include only from code built for the batch's ISA (packet/kernel.hpp).
#pragma once

#include <cstdint>
#include <limits>
#include <type_traits>
#include <utility>
#include <xsimd/xsimd.hpp>

#include "lancer/formulas.hpp"
#include "lancer/packet/lanes.hpp"
#include "lancer/packet/prim/shapes_walk.hpp"
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

template <class Arch, class T>
struct ShapeLone {
  using Shapes = PreparedShapes<T>;
  using Wide = typename Shapes::WideNode;
  using C = xsimd::batch<T, typename LoneArch<Arch, T>::type>;
  using CM = xsimd::batch_bool<T, typename LoneArch<Arch, T>::type>;
  using CV = Vec3<C>;
  static constexpr int kC = static_cast<int>(C::size);
  static constexpr int kW = Shapes::kWide;
  static constexpr int kParts = kW / kC;  // registers per node's children
  static constexpr T kWiden = sizeof(T) == 4 ? T(0x1p-20) : T(0x1p-49);
  static_assert(kW % kC == 0);

  // One ray as the tests see it: the reference's shear, and the packet walk's slab form.
  struct Ray {
    T o[3], d[3];
    prim::RayShear<T> shear;
    T o_perm[3];  // o in the shear's axis order
    T inv[3];     // 1 / d, 1 where d is 0
    bool zero[3];
    T o_pad, o_lo[3], o_hi[3], o_near[3], o_far[3];
    int near[3], far[3];  // offsets (in T) in a WideNode of each axis' entry and exit planes
    unsigned code = 0;
    bool fast = true;  // every |d| at least 2^-60: entry and exit planes known per axis

    Ray() = default;
    // A packet's lane, its shear and quotients as the packet's Ray (shapes_walk.hpp) computed
    // them, by ray_shear's comparisons and the same divisions: axes kx, ky, kz; f = sx, sy, sz,
    // then 1 / d per axis (1 where 0).
    Ray(const T* org, const T* dir, const int* axes, const T* f) noexcept {
      for (int a = 0; a < 3; ++a) o[a] = org[a], d[a] = dir[a], inv[a] = f[3 + a];
      shear.kx = axes[0], shear.ky = axes[1], shear.kz = axes[2];
      shear.sx = f[0], shear.sy = f[1], shear.sz = f[2];
      o_perm[0] = o[shear.kx], o_perm[1] = o[shear.ky], o_perm[2] = o[shear.kz];
      T mag = 0;
      for (int a = 0; a < 3; ++a) {
        const T m = o[a] < T(0) ? -o[a] : o[a];
        mag = m > mag ? m : mag;
      }
      o_pad = T(Shapes::kWidePad) * mag;
      for (int a = 0; a < 3; ++a) {
        zero[a] = d[a] == T(0);
        o_lo[a] = o[a] + o_pad, o_hi[a] = o[a] - o_pad;
        const bool down = d[a] < T(0);
        const T ad = down ? -d[a] : d[a];
        fast = fast && ad >= T(0x1p-60);
        near[a] = down ? Shapes::hi_plane(a) : Shapes::lo_plane(a);
        far[a] = down ? Shapes::lo_plane(a) : Shapes::hi_plane(a);
        o_near[a] = down ? o_hi[a] : o_lo[a], o_far[a] = down ? o_lo[a] : o_hi[a];
        code |= unsigned(d[a] >= T(0)) << a;
      }
    }
  };

  // The children of n (slot bits) whose boxes [0, lim_w] may meet, and their entry t (widened):
  // shapes_walk.hpp's child_lanes with one ray in every lane and the children across lanes.
  static unsigned met_children(const Wide& n, const Ray& r, T lim_w, T* t0_out) noexcept {
    unsigned met = 0;
    const T* base = &n.lo_x[0];
    for (int h = 0; h < kParts; ++h) {
      auto plane = [&](int off) { return C::load_aligned(base + off + h * kC); };
      C t0;
      CM in;
      if (r.fast) {
        const C nx = (plane(r.near[0]) - C(r.o_near[0])) * C(r.inv[0]);
        const C fx = (plane(r.far[0]) - C(r.o_far[0])) * C(r.inv[0]);
        const C ny = (plane(r.near[1]) - C(r.o_near[1])) * C(r.inv[1]);
        const C fy = (plane(r.far[1]) - C(r.o_far[1])) * C(r.inv[1]);
        const C nz = (plane(r.near[2]) - C(r.o_near[2])) * C(r.inv[2]);
        const C fz = (plane(r.far[2]) - C(r.o_far[2])) * C(r.inv[2]);
        t0 = xsimd::max(xsimd::max(nx, ny), xsimd::max(nz, C(T(0)))) * C(T(1) - kWiden);
        const C t1 = xsimd::min(xsimd::min(fx, fy), fz) * C(T(1) + kWiden);
        in = t0 <= xsimd::min(t1, C(lim_w));
      } else {
        const C inf(std::numeric_limits<T>::infinity());
        C near(T(0)), far(lim_w);
        CM out(false);
        for (int a = 0; a < 3; ++a) {
          const C lo_t = plane(Shapes::lo_plane(a)), hi_t = plane(Shapes::hi_plane(a));
          if (r.zero[a]) {
            const C lo = lo_t - C(r.o_pad), hi = hi_t + C(r.o_pad);
            out = out | (C(r.o[a]) < lo) | (C(r.o[a]) > hi);
            continue;
          }
          const C ea = (lo_t - C(r.o_lo[a])) * C(r.inv[a]);
          const C eb = (hi_t - C(r.o_hi[a])) * C(r.inv[a]);
          near = xsimd::max(near, xsimd::min(ea, eb));
          far = xsimd::min(far, xsimd::max(ea, eb) * C(T(1) + kWiden));
        }
        t0 = near * C(T(1) - kWiden);
        in = ~out & (t0 <= far);
      }
      t0.store_unaligned(t0_out + h * kC);
      met |= lane_bits(in) << (h * kC);
    }
    return met & ((1u << n.arity) - 1);
  }

  using Packet = ShapeWalk<Arch, T>;  // its node order and prefetch serve one ray too
  // Visits the leaves whose boxes the ray may meet before limit() (re-read after each leaf),
  // children nearest first: leaf(first, count) returns true to stop.
  template <class Limit, class Leaf>
  static void walk(const Shapes& sh, const Ray& r, Limit&& limit, Leaf&& leaf,
                   std::int32_t child = 0, unsigned count = 0) noexcept {
    if (sh.wide.empty()) return;
    std::int32_t st_child[Shapes::kWideStack];
    std::uint8_t st_count[Shapes::kWideStack];
    T st_t0[Shapes::kWideStack];
    int sp = 0;
    const T widen = T(1) + kWiden;
    for (;;) {
      if (count == 0) {
        const Wide& n = sh.wide[std::size_t(child)];
        alignas(32) T t0[kW];
        const unsigned met = met_children(n, r, limit() * widen, t0);
        if (met != 0) {
          int slots[kW];
          const int c = Packet::near_first(n, r.code, met, slots);
          for (int q = c - 1; q >= 0; --q) {
            const int s = slots[q];
            Packet::prefetch(sh, n.child[s], n.count[s]);
            if (q == 0) break;
            st_child[sp] = n.child[s], st_count[sp] = n.count[s], st_t0[sp] = t0[s];
            ++sp;
          }
          child = n.child[slots[0]], count = n.count[slots[0]];
          continue;
        }
      } else if (leaf(std::uint32_t(child), count)) {
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

  // Component q of the vertices at v[0], v[1], ... across the lanes.
  template <std::size_t... K>
  static C lanes_of(const T* const* v, int q, std::index_sequence<K...>) noexcept {
    return C{v[K][q]...};
  }

  // Leaf-order primitives [j, j + n) (n <= kC), triangles only in lanes: their hits t beyond
  // eps, in t_out. Returns the lanes hit (none past n or on a cylinder).
  static unsigned triangles_t(const Shapes& sh, std::uint32_t j, unsigned n, const Ray& r, T eps,
                              T* t_out) noexcept {
    const T* v[kC];
    unsigned tri = 0;
    for (unsigned k = 0; k < n; ++k)
      if (sh.leaf[j + k].ref >= 0) tri |= 1u << k, v[k] = sh.leaf[j + k].v;
    if (tri == 0) return 0;
    // Lanes without a triangle repeat the first (masked out below), so that no zero edge
    // function sends the register through the exact recomputation.
    const T* first = v[__builtin_ctz(tri)];
    for (int k = 0; k < kC; ++k)
      if (!(tri >> k & 1u)) v[k] = first;
    const int perm[3] = {r.shear.kx, r.shear.ky, r.shear.kz};
    auto vertex = [&](int c) {
      CV p;
      C* out[3] = {&p.x, &p.y, &p.z};
      for (int a = 0; a < 3; ++a)
        *out[a] = lanes_of(v, 3 * c + perm[a], std::make_index_sequence<kC>{}) - C(r.o_perm[a]);
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

  // The sphere of leaf record v (centre, squared radius): its nearest hit beyond eps, infinity
  // where none, by the reference's formulas.
  static T sphere_t(const T* v, const Ray& r, T eps) noexcept {
    const T inf = std::numeric_limits<T>::infinity();
    const Vec3<T> f{r.o[0] - v[0], r.o[1] - v[1], r.o[2] - v[2]}, d{r.d[0], r.d[1], r.d[2]};
    const SphereDisc<T> sd = sphere_disc(f, d, v[3]);
    if (!(sd.disc >= T(0))) return inf;
    const T t = sphere_first_root(sphere_roots(sd, sphere_c(f, v[3])), eps);
    return t > eps ? t : inf;
  }

  // Leaf-order items [begin, begin + size), kC at a time: hit(j, t) for each triangle the ray
  // meets beyond eps (t its hit), then each cylinder and sphere of those kC (t its nearest hit
  // beyond eps, infinity where none); true from hit stops.
  template <class Hit>
  static bool leaf_hits(const Shapes& sh, const Ray& r, T eps, std::uint32_t begin, unsigned size,
                        Hit&& hit) noexcept {
    for (unsigned j = 0; j < size; j += unsigned(kC)) {
      const unsigned n = size - j < unsigned(kC) ? size - j : unsigned(kC);
      alignas(32) T t[kC];
      for (unsigned m = triangles_t(sh, begin + j, n, r, eps, t); m; m &= m - 1) {
        const unsigned k = unsigned(__builtin_ctz(m));
        if (hit(begin + j + k, t[k])) return true;
      }
      for (unsigned k = 0; k < n; ++k) {
        const auto& p = sh.leaf[begin + j + k];
        if (p.ref >= 0) continue;
        const T tk =
            p.ref == Shapes::kSphereRef ? sphere_t(p.v, r, eps) : cylinder_t(sh, p.ref, r, eps);
        if (hit(begin + j + k, tk)) return true;
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
    walk(
        sh, r, [&] { return best_t; },
        [&](std::uint32_t begin, unsigned size) {
          return leaf_hits(sh, r, eps, begin, size, [&](std::uint32_t j, T t) {
            consider(t, sh.leaf[j].prim);
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
    walk(
        sh, r, [&] { return dist; },
        [&](std::uint32_t begin, unsigned size) {
          return leaf_hits(sh, r, eps, begin, size,
                           [&](std::uint32_t, T t) { return found = t < dist; });
        },
        child, count);
    return found;
  }
};

}  // namespace lancer::packet
