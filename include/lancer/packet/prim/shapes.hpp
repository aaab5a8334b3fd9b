// Triangles, meshes and cylinders, a primitive module of the packets. Their own hierarchy
// (lancer/shapes.hpp: a binary SAH tree over every triangle and cylinder) is walked by the whole
// packet after the planes, as their ids come after the planes'. The tests are the reference's
// formula helpers (prim/triangle.hpp, prim/cylinder.hpp) on batches: the triangle test shears
// each lane by its own axes, picked per lane, so every lane gets the reference's bits.
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
#include <vector>

#include "lancer/packet/lane_traits.hpp"
#include "lancer/prim/cylinder.hpp"
#include "lancer/prim/triangle.hpp"
#include "lancer/shapes.hpp"

namespace lancer::packet {

template <class Arch, class Real, class Mode>
struct ShapePackets : Lanes<Arch, Real, Mode> {
  using L = Lanes<Arch, Real, Mode>;
  using L::bits;
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

  // v's component k per lane, k given as the masks k == 0 and k == 1.
  static B pick(const V& v, const M& is0, const M& is1) noexcept {
    return xsimd::select(is0, v.x, xsimd::select(is1, v.y, v.z));
  }

  // The packet as the tests see it: each lane's shear (prim::ray_shear, lane by lane: its axes
  // as masks), and the box test's reciprocal directions.
  struct Ray {
    V o, d;
    M x0, x1, y0, y1, z0, z1;  // kx == 0, kx == 1, ky == 0, ...
    B sx, sy, sz;
    V inv;                     // 1 / d, 1 where d is 0
    M zero_x, zero_y, zero_z;  // d's zero components: the box test asks o to lie in the slab
    B o_mag;                   // |o|inf, for the box's margin
    T heading[3];              // the lanes' directions summed: the walk's order of children

    Ray(const V& org, const V& dir) noexcept : o(org), d(dir) {
      const B ax = xsimd::abs(d.x), ay = xsimd::abs(d.y), az = xsimd::abs(d.z);
      // kz: the largest component (ray_shear's comparisons); kx, ky the next two in turn.
      const M kz0 = (ax > ay) & (ax > az), kz1 = ~(ax > ay) & (ay > az);
      const M kz2 = ~(kz0 | kz1);
      z0 = kz0, z1 = kz1;
      const B dz = pick(d, z0, z1);
      // kx = kz + 1 and ky = kz + 2 (mod 3), swapped where d[kz] < 0 to keep the winding.
      const M neg = dz < B(0);
      auto either = [&](const M& a, const M& b) { return (neg & a) | (~neg & b); };
      x0 = either(kz1, kz2), x1 = either(kz2, kz0);
      y0 = either(kz2, kz1), y1 = either(kz0, kz2);
      sx = pick(d, x0, x1) / dz;
      sy = pick(d, y0, y1) / dz;
      sz = B(T(1)) / dz;
      zero_x = d.x == B(0), zero_y = d.y == B(0), zero_z = d.z == B(0);
      inv = {B(T(1)) / xsimd::select(zero_x, B(T(1)), d.x),
             B(T(1)) / xsimd::select(zero_y, B(T(1)), d.y),
             B(T(1)) / xsimd::select(zero_z, B(T(1)), d.z)};
      o_mag = xsimd::max(xsimd::max(xsimd::abs(o.x), xsimd::abs(o.y)), xsimd::abs(o.z));
      const B* comp[3] = {&d.x, &d.y, &d.z};
      for (int k = 0; k < 3; ++k) {  // (xsimd's hadd needs AVX-512 DQ at width 16)
        alignas(64) T v[W];
        comp[k]->store_aligned(v);
        heading[k] = T(0);
        for (int l = 0; l < W; ++l) heading[k] += v[l];
      }
    }
    V permuted(const V& v) const noexcept {
      return {pick(v, x0, x1), pick(v, y0, y1), pick(v, z0, z1)};
    }
  };

  // The lanes whose segment [0, limit] may meet the node's box: the reference's margins (the
  // watertight test's reach outside a triangle, SlabRay in shapes.cpp) doubled, and each slab's
  // entry and exit widened by more than the float (or double) roundings of their computation.
  static M box_lanes(const typename Shapes::Node& node, const Ray& r, const M& lanes,
                     const B& limit) noexcept {
    constexpr T kPad = sizeof(T) == 4 ? T(0x1p-18) : T(0x1p-47);
    constexpr T kWiden = sizeof(T) == 4 ? T(0x1p-20) : T(0x1p-49);
    T mag = 0;
    for (int k = 0; k < 3; ++k) mag = std::max({mag, std::abs(node.lo[k]), std::abs(node.hi[k])});
    const B pad = B(kPad) * (r.o_mag + B(mag));
    const B inf(std::numeric_limits<T>::infinity());
    B t0(T(0)), t1 = limit * B(T(1) + kWiden);
    M out = ~lanes;
    auto slab = [&](int k, const B& o, const B& inv, const M& zero) {
      const B lo = B(node.lo[k]) - pad, hi = B(node.hi[k]) + pad;
      const B a = (lo - o) * inv, b = (hi - o) * inv;
      const B near = xsimd::select(zero, -inf, xsimd::min(a, b) * B(T(1) - kWiden));
      const B far = xsimd::select(zero, inf, xsimd::max(a, b) * B(T(1) + kWiden));
      out = out | (zero & ((o < lo) | (o > hi)));
      t0 = xsimd::max(t0, near);
      t1 = xsimd::min(t1, far);
    };
    slab(0, r.o.x, r.inv.x, r.zero_x);
    slab(1, r.o.y, r.inv.y, r.zero_y);
    slab(2, r.o.z, r.inv.z, r.zero_z);
    return ~out & (t0 <= t1);
  }

  // The nearest hit of primitive p (its reference `ref`: a triangle >= 0, else ~cylinder)
  // beyond eps, infinity where none.
  static B prim_t(const Shapes& sh, std::int32_t ref, const Ray& r, const B& eps) noexcept {
    const B inf(std::numeric_limits<T>::infinity());
    if (ref >= 0) {
      const std::uint32_t* v = &sh.tri[3 * std::size_t(ref)];
      auto vertex = [&](std::uint32_t k) {
        return r.permuted(V{B(sh.vx[k]) - r.o.x, B(sh.vy[k]) - r.o.y, B(sh.vz[k]) - r.o.z});
      };
      const prim::TriangleEdges<B> e =
          prim::triangle_edges<T>(vertex(v[0]), vertex(v[1]), vertex(v[2]), r.sx, r.sy, r.sz);
      const B t = prim::triangle_t(e);
      return xsimd::select(prim::triangle_inside(e) & (t > eps), t, inf);
    }
    const std::size_t c = std::size_t(~ref);
    const Vec3<T>& a = sh.cyl_base[c];
    const Vec3<T>& ax = sh.cyl_axis[c];
    return prim::cylinder_closest(r.o - V{B(a.x), B(a.y), B(a.z)}, r.d,
                                  V{B(ax.x), B(ax.y), B(ax.z)}, B(sh.cyl_h[c]), B(sh.cyl_r2[c]),
                                  sh.cyl_caps[c] != 0, eps)
        .t;
  }

  // Visits the leaves of the shapes' hierarchy that some lane of `lanes` may reach before
  // limit(): leaf(first, count, lanes_at_leaf) returns true to stop.
  template <class Limit, class Leaf>
  [[gnu::always_inline]] static void walk(const Shapes& sh, const Ray& r, const M& lanes,
                                          Limit&& limit, Leaf&& leaf) noexcept {
    if (sh.nodes.empty()) return;
    std::uint32_t stack[Shapes::kMaxTreeDepth];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const auto& node = sh.nodes[stack[--top]];
      const M at = box_lanes(node, r, lanes, limit());
      if (!xsimd::any(at)) continue;
      if (node.count > 0) {
        if (leaf(node.first, node.count, at)) return;
        continue;
      }
      // The child nearer along the packet's direction first (pushed last): on the axis that
      // parts the children's centres most. Only the order: every box is tested all the same.
      const auto& a = sh.nodes[node.first];
      const auto& b = sh.nodes[node.first + 1];
      int axis = 0;
      T apart = 0;
      for (int k = 0; k < 3; ++k) {
        const T gap = (b.lo[k] + b.hi[k]) - (a.lo[k] + a.hi[k]);
        if (std::abs(gap) > std::abs(apart)) apart = gap, axis = k;
      }
      const bool a_first = apart * r.heading[axis] >= T(0);
      stack[top++] = a_first ? node.first + 1 : node.first;
      stack[top++] = a_first ? node.first : node.first + 1;
    }
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
    const Ray r(o, d);
    const B eps(s.epsilon);
    const Id first = Id(first_id(s));
    walk(
        sh, r, valid, [&] { return best_t; },
        [&](std::uint32_t begin, std::uint32_t n, const M& at) {
          for (std::uint32_t j = begin; j < begin + n; ++j) {
            const std::uint32_t p = sh.order[j];
            tests(counts, at, false);
            const B t = prim_t(sh, sh.prim[p], r, eps);
            const I pid(Id(first + Id(p)));
            const M tie = (t == best_t) & to_m((best_id >= I(first)) & (pid < best_id));
            const M take = at & ((t < best_t) | tie);
            best_t = xsimd::select(take, t, best_t);
            best_id = xsimd::select(to_mi(take), pid, best_id);
          }
          return false;
        });
    return {best_t, best_id};
  }

  // The object id of one hit id (unchanged below first_id).
  static std::int32_t object_of(const Prepared& s, std::int32_t hit_id) noexcept {
    const int first = first_id(s);
    if (hit_id < first) return hit_id;
    const std::int32_t ref = s.shapes->prim[std::size_t(hit_id - first)];
    return ref >= 0 ? s.shapes->tri_object[std::size_t(ref)]
                    : s.shapes->cyl_object[std::size_t(~ref)];
  }
  // The object ids of hit ids (unchanged below first_id).
  [[gnu::noinline]] static I object_of(const Prepared& s, I hit_id) noexcept {
    const Shapes& sh = *s.shapes;
    const Id first = Id(first_id(s));
    if (!xsimd::any(hit_id >= I(first))) return hit_id;
    alignas(64) Id v[W];
    hit_id.store_aligned(v);
    for (int k = 0; k < W; ++k) {
      if (v[k] < first) continue;
      const std::int32_t ref = sh.prim[std::size_t(v[k] - first)];
      v[k] = ref >= 0 ? sh.tri_object[std::size_t(ref)] : sh.cyl_object[std::size_t(~ref)];
    }
    return I::load_aligned(v);
  }

  // Any hit over the shapes for the lanes still pending, from p along unit l before `dist`:
  // step(object, lanes, pending) for each object the lanes meet beyond eps, each once per lane,
  // in ascending object id (the reference's order: a float product of three or more
  // transmittances depends on it). The walk is out of line (met_objects), for the reason given
  // at closest().
  template <class Step>
  [[gnu::always_inline]] static M any(const Prepared& s, M pending, const V& p, const V& l,
                                      const B& dist, const B& eps, RayCounts& counts,
                                      Step& step) noexcept {
    const MetList met = met_objects(s, pending, p, l, dist, eps, counts);
    for (std::size_t k = 0; k < met.n && xsimd::any(pending); ++k) {
      const M m = pending & from_bits(met.data[k].lanes);
      if (xsimd::any(m)) pending = step(Id(met.data[k].object), m, pending);
    }
    return pending;
  }

  static int object(const Shapes& sh, std::int32_t ref) noexcept {
    return ref >= 0 ? sh.tri_object[std::size_t(ref)] : sh.cyl_object[std::size_t(~ref)];
  }

  // The objects a packet of shadow segments meets, each with the lanes that meet it, in
  // ascending object id. Opaque scenes: a lane is done at its first object (in one entry at
  // most). The list lives in a buffer of the thread's, valid until its next call.
  struct Met {
    int object;
    unsigned lanes;
  };
  struct MetList {
    const Met* data;
    std::size_t n;
  };
  [[gnu::noinline]] static MetList met_objects(const Prepared& s, M pending, V p, V l, B dist,
                                               B eps, RayCounts& counts) noexcept {
    const Shapes& sh = *s.shapes;
    const Ray r(p, l);
    const bool first_only = !s.features.transparency;
    thread_local std::vector<Met> met;
    met.clear();
    walk(
        sh, r, pending, [&] { return dist; },
        [&](std::uint32_t begin, std::uint32_t n, const M& at) {
          for (std::uint32_t j = begin; j < begin + n; ++j) {
            const std::uint32_t q = sh.order[j];
            const M lanes = at & pending;
            tests(counts, lanes, false);
            const M hit = lanes & (prim_t(sh, sh.prim[q], r, eps) < dist);
            if (!xsimd::any(hit)) continue;
            const int obj = object(sh, sh.prim[q]);
            auto it =
                std::find_if(met.begin(), met.end(), [&](const Met& m) { return m.object == obj; });
            if (it == met.end()) it = met.insert(met.end(), Met{obj, 0u});
            it->lanes |= bits(hit);
            if (!first_only) continue;
            pending = pending & ~hit;
            if (!xsimd::any(pending)) return true;
          }
          return false;
        });
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
    const Ray r(o, d);
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
