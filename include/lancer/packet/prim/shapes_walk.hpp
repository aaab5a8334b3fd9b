// The packets' walk of the shapes' wide hierarchy (PreparedShapes::wide) and their triangle test
// on a leaf's vertices, apart from the shape module's bookkeeping (packet/prim/shapes.hpp).
//
// The box test is conservative: it never turns away a box the reference's (double, padded)
// test accepts, so the closest hit, the least (t, primitive), does not depend on it. The
// reference grows each box by 2^-19 (float; 2^-48 for double) of |origin|inf + |box|inf for the
// watertight test's reach outside a triangle; the walk twice that: the wide boxes are stored
// grown by kWidePad |box|inf (rounded outwards), the lanes' origins move by kWidePad |o|inf
// towards each plane, and each slab's entry and exit widen by more than the float (or double)
// roundings of their computation. The extra half of the margin covers this form's roundings.
// A slab's distance is plane * inv - oi, oi the moved origin times inv rounded once, in one
// fused operation where the ISA has one (fused.hpp's fmsub and slab_fmsub; SSE4.2 rounds the
// product too): oi's rounding moves the origin by at most 2^-24 (2^-53) of |o|inf, well within
// that extra half, and the rest is a relative rounding of the distance, which the widening
// covers.
// Include only from code built for the batch's ISA (packet/kernel.hpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <type_traits>

#include "lancer/packet/fused.hpp"
#include "lancer/packet/lane_traits.hpp"
#include "lancer/prim/triangle.hpp"
#include "lancer/shapes.hpp"

namespace lancer::packet {

template <class Arch, class T>
struct ShapeWalk {
  using B = xsimd::batch<T, Arch>;
  using M = xsimd::batch_bool<T, Arch>;
  using V = Vec3<B>;
  using Shapes = PreparedShapes<T>;
  using Wide = typename Shapes::WideNode;
  static constexpr int W = static_cast<int>(B::size);
  static constexpr int kW = Shapes::kWide;
  static constexpr T kWiden = sizeof(T) == 4 ? T(0x1p-20) : T(0x1p-49);
  // The walks read a child's planes at these offsets from lo_x.
  static_assert(offsetof(Wide, lo_z) == sizeof(T) * Shapes::lo_plane(2) &&
                offsetof(Wide, hi_z) == sizeof(T) * Shapes::hi_plane(2));

  // The box test's forms, by what every live lane's direction has: fast, the same sign per axis
  // over the lanes and no component below 2^-60 in magnitude (the entry and exit planes known
  // per packet); no_zero, no zero component (each lane's slab the min and max of its two
  // planes' distances, with no case for an origin that must lie within a slab: incoherent
  // packets); generic, anything. Where a form applies, it gives what the generic one gives.
  enum class BoxTest { generic, no_zero, fast };

  // v's component k per lane, k given as the masks k == 0 and k == 1.
  static B pick(const V& v, const M& is0, const M& is1) noexcept {
    return xsimd::select(is0, v.x, xsimd::select(is1, v.y, v.z));
  }
  static const B& axis(const V& v, int k) noexcept { return k == 0 ? v.x : k == 1 ? v.y : v.z; }
  static B& axis(V& v, int k) noexcept { return k == 0 ? v.x : k == 1 ? v.y : v.z; }

  // The packet as the tests see it: each lane's shear (prim::ray_shear, lane by lane: its axes
  // as masks; one scalar permutation where every live lane has the same axes), and the box
  // test's form of the rays.
  struct Ray {
    V o, d;
    M x0, x1, y0, y1, z0, z1;  // kx == 0, kx == 1, ky == 0, ...
    B sx, sy, sz;
    V inv;                     // 1 / d, 1 where d is 0
    M zero_x, zero_y, zero_z;  // d's zero components: the box test asks o to lie in the slab
    B o_pad;                   // kWidePad |o|inf: the origin's share of the boxes' margin
    // o + o_pad or o - o_pad per axis (the origins the lower and upper planes see): those of
    // the near and far planes (the frustum's bounds, shapes_frustum.hpp).
    V o_near, o_far;
    // The slabs' offsets, the origin times inv (plane inv - o inv): the lower and upper planes',
    // the near and far ones' (the fast form).
    V oi_lo, oi_hi, oi_near, oi_far;
    unsigned code = 0;  // direction code: bit a set where the lanes' summed d goes up a
    // Every live lane has the same axes (kx, ky, kz): the vertices are permuted once, scalar.
    bool uniform = false;
    int row_x = 0, row_y = 0, row_z = 0;  // where uniform: kx, ky, kz's offsets in a leaf's column
    V o_perm;                             // o permuted into (kx, ky, kz), where uniform
    // The fast box test: every live lane's |d| is at least 2^-60 on every axis (no zero, no
    // overflow) and its sign is the same on each axis; near[a], far[a]: the offsets (in T) in a
    // WideNode of axis a's planes the rays enter and leave by.
    bool fast = false;
    bool no_zero = false;  // no live lane's direction has a zero component (BoxTest::no_zero)
    int near[3] = {Shapes::lo_plane(0), Shapes::lo_plane(1), Shapes::lo_plane(2)};
    int far[3] = {Shapes::hi_plane(0), Shapes::hi_plane(1), Shapes::hi_plane(2)};

    Ray(const V& org, const V& dir, const M& valid) noexcept : o(org), d(dir) {
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
      const B o_mag = xsimd::max(xsimd::max(xsimd::abs(o.x), xsimd::abs(o.y)), xsimd::abs(o.z));
      o_pad = B(T(Shapes::kWidePad)) * o_mag;
      const V o_lo{o.x + o_pad, o.y + o_pad, o.z + o_pad};
      const V o_hi{o.x - o_pad, o.y - o_pad, o.z - o_pad};
      oi_lo = {o_lo.x * inv.x, o_lo.y * inv.y, o_lo.z * inv.z};
      oi_hi = {o_hi.x * inv.x, o_hi.y * inv.y, o_hi.z * inv.z};
      const M dead = ~valid;
      auto all = [&](const M& m) { return xsimd::all(m | dead); };
      const int kzs = all(kz0) ? 0 : all(kz1) ? 1 : all(kz2) ? 2 : -1;
      const bool all_neg = all(neg), all_pos = all(~neg);
      if (kzs >= 0 && (all_neg || all_pos)) {
        uniform = true;
        const int kz = kzs;
        int kx = kz == 2 ? 0 : kz + 1;
        int ky = kx == 2 ? 0 : kx + 1;
        if (all_neg) std::swap(kx, ky);
        o_perm = {axis(o, kx), axis(o, ky), axis(o, kz)};
        const int items = Shapes::kLeafItems;
        row_x = items * kx, row_y = items * ky, row_z = items * kz;
      }
      set_code(valid, o_lo, o_hi);
    }
    // The direction code, whether the fast box test holds, and the near and far planes' origins
    // and offsets (o_lo: o + o_pad, o_hi: o - o_pad).
    void set_code(const M& valid, const V& o_lo, const V& o_hi) noexcept {
      const B tiny(T(0x1p-60));
      const M dead = ~valid;
      fast = true;
      no_zero = xsimd::all(dead | ~(zero_x | zero_y | zero_z));
      const B* comp[3] = {&d.x, &d.y, &d.z};
      for (int a = 0; a < 3; ++a) {
        const B& c = *comp[a];
        const bool up = xsimd::all((c > B(T(0))) | dead);
        const bool down = !up && xsimd::all((c < B(T(0))) | dead);
        fast = fast && (up || down) && xsimd::all((xsimd::abs(c) >= tiny) | dead);
        near[a] = down ? Shapes::hi_plane(a) : Shapes::lo_plane(a);
        far[a] = down ? Shapes::lo_plane(a) : Shapes::hi_plane(a);
        axis(o_near, a) = axis(down ? o_hi : o_lo, a);
        axis(o_far, a) = axis(down ? o_lo : o_hi, a);
        axis(oi_near, a) = axis(down ? oi_hi : oi_lo, a);
        axis(oi_far, a) = axis(down ? oi_lo : oi_hi, a);
        // Lanes of one sign: their sum has it (no sum to wait for).
        if (up || down) {
          code |= unsigned(up) << a;
          continue;
        }
        code |= unsigned(lanes_sum_up(valid, c)) << a;
      }
    }
    V permuted(const V& v) const noexcept {
      return {pick(v, x0, x1), pick(v, y0, y1), pick(v, z0, z1)};
    }
  };

  // f(form) with the box test's form for r (an std::integral_constant of BoxTest): the one
  // place the walks choose it.
  template <class F>
  [[gnu::always_inline]] static void with_box_test(const Ray& r, F&& f) noexcept {
    if (r.fast)
      f(std::integral_constant<BoxTest, BoxTest::fast>{});
    else if (r.no_zero)
      f(std::integral_constant<BoxTest, BoxTest::no_zero>{});
    else
      f(std::integral_constant<BoxTest, BoxTest::generic>{});
  }

  // The lanes of `lanes` whose segment [0, limit] may meet child k's box (lim_w: limit widened
  // by 1 + kWiden); t0: where they enter it, widened (the walk culls popped subtrees by it).
  template <BoxTest kTest>
  [[gnu::always_inline]] static M child_lanes(const Wide& n, int k, const Ray& r, const M& lanes,
                                              const B& lim_w, B& t0) noexcept {
    if constexpr (kTest == BoxTest::fast) {
      // Every lane's direction has the same signs: entry and exit planes known per packet,
      // the values of the generic form's min and max (rounding is monotonic).
      const T* base = &n.lo_x[0] + k;
      auto plane = [&](int off) { return B(base[off]); };
      const B nx = fmsub(plane(r.near[0]), r.inv.x, r.oi_near.x);
      const B fx = fmsub(plane(r.far[0]), r.inv.x, r.oi_far.x);
      const B ny = fmsub(plane(r.near[1]), r.inv.y, r.oi_near.y);
      const B fy = fmsub(plane(r.far[1]), r.inv.y, r.oi_far.y);
      const B nz = fmsub(plane(r.near[2]), r.inv.z, r.oi_near.z);
      const B fz = fmsub(plane(r.far[2]), r.inv.z, r.oi_far.z);
      t0 = xsimd::max(xsimd::max(nx, ny), xsimd::max(nz, B(T(0)))) * B(T(1) - kWiden);
      const B t1 = xsimd::min(xsimd::min(fx, fy), fz) * B(T(1) + kWiden);
      return lanes & (t0 <= xsimd::min(t1, lim_w));
    } else {
      // Per plane, each lane's slab the min and max of its two distances. generic: a lane with
      // a zero component on an axis has no distance there (a select drops it) and must start
      // within that slab; no_zero leaves out those selects and checks (no lane needs them),
      // the same operations on the same values otherwise.
      constexpr bool kZero = kTest == BoxTest::generic;
      const B inf(std::numeric_limits<T>::infinity());
      B near(T(0)), far = lim_w;
      M out = ~lanes;
      auto slab = [&](T lo_t, T hi_t, const B& o, const B& oilo, const B& oihi, const B& inv,
                      const M& zero) {
        const B a = fmsub(B(lo_t), inv, oilo), b = fmsub(B(hi_t), inv, oihi);
        if constexpr (kZero) {
          const B lo = B(lo_t) - r.o_pad, hi = B(hi_t) + r.o_pad;
          near = xsimd::max(near, xsimd::select(zero, -inf, xsimd::min(a, b)));
          far = xsimd::min(far, xsimd::select(zero, inf, xsimd::max(a, b) * B(T(1) + kWiden)));
          out = out | (zero & ((o < lo) | (o > hi)));
        } else {
          near = xsimd::max(near, xsimd::min(a, b));
          far = xsimd::min(far, xsimd::max(a, b) * B(T(1) + kWiden));
        }
      };
      slab(n.lo_x[k], n.hi_x[k], r.o.x, r.oi_lo.x, r.oi_hi.x, r.inv.x, r.zero_x);
      slab(n.lo_y[k], n.hi_y[k], r.o.y, r.oi_lo.y, r.oi_hi.y, r.inv.y, r.zero_y);
      slab(n.lo_z[k], n.hi_z[k], r.o.z, r.oi_lo.z, r.oi_hi.z, r.inv.z, r.zero_z);
      t0 = near * B(T(1) - kWiden);
      return ~out & (t0 <= far);
    }
  }

  // Starts loading a subtree's node (count 0) or leaf, for when it is popped. Always inlined: the
  // frustum walk calls it for every child of every node it enters.
  [[gnu::always_inline]] static void prefetch(const Shapes& sh, std::int32_t child,
                                              unsigned count) noexcept {
    if (count == 0)
      prefetch_lines(&sh.wide[std::size_t(child)], sizeof(Wide));
    else
      prefetch_lines(&sh.leaves[std::size_t(child)], sizeof(sh.leaves[0]));
  }

  // The slots of node n's met children (bits of `met`), nearest first for direction code
  // `code`, into slots: their count.
  static int near_first(const Wide& n, unsigned code, unsigned met, int (&slots)[kW]) noexcept {
    const unsigned order = n.order[code];
    int c = 0;
    for (int p = 0; p < kW; ++p) {
      const int s = int(order >> (Shapes::kOrderBits * p)) & (kW - 1);
      if (met >> s & 1u) slots[c++] = s;
    }
    return c;
  }

  // The packet walks' subtrees still to visit, each with its lanes and their entry t.
  struct Stack {
    std::int32_t child[Shapes::kWideStack];
    std::uint8_t count[Shapes::kWideStack];
    M mask[Shapes::kWideStack];
    B t0[Shapes::kWideStack];
    int sp = 0;

    // Node n's met children (bits of `met`, lanes m[k] entering at t0s[k]), nearest first by
    // direction code `code`: the nearest becomes (at, at_count, at_mask), the others are pushed.
    [[gnu::always_inline]] void descend(const Wide& n, unsigned code, unsigned met, const M* m,
                                        const B* t0s, std::int32_t& at, unsigned& at_count,
                                        M& at_mask) noexcept {
      int slots[kW];
      const int c = near_first(n, code, met, slots);
      for (int q = c - 1; q > 0; --q) {
        const int s = slots[q];
        child[sp] = n.child[s], count[sp] = n.count[s];
        mask[sp] = m[s], t0[sp] = t0s[s];
        ++sp;
      }
      at = n.child[slots[0]], at_count = n.count[slots[0]], at_mask = m[slots[0]];
    }
    // The next subtree some lane may still reach before its limit (lim_w(): the limits,
    // widened), into (at, at_count, at_mask); false when none is left.
    template <class LimW>
    [[gnu::always_inline]] bool pop(LimW&& lim_w, std::int32_t& at, unsigned& at_count,
                                    M& at_mask) noexcept {
      while (sp > 0) {
        --sp;
        at_mask = mask[sp] & (t0[sp] <= lim_w());
        if (xsimd::any(at_mask)) {
          at = child[sp], at_count = count[sp];
          return true;
        }
      }
      return false;
    }
  };

  // Visits the leaves of the wide hierarchy that some lane of `lanes` may reach before limit()
  // (re-read after each leaf: popped subtrees are culled by it), children nearest first by the
  // packet's direction code: leaf(leaf index, count, lanes_at_leaf) returns true to stop.
  template <BoxTest kTest, class Limit, class Leaf>
  [[gnu::always_inline]] static void walk(const Shapes& sh, const Ray& r, const M& lanes,
                                          Limit& limit, Leaf& leaf) noexcept {
    auto never = [](std::int32_t, unsigned, const M&) { return false; };
    walk_lanes<kTest, false>(sh, r, lanes, limit, leaf, never, 0);
  }

  // The same walk with the hybrid switch (Benthin et al.) where kHybrid: a subtree (a node or a
  // leaf) that `lone` live lanes or fewer reach goes to alone(child, count, lanes), which walks
  // it for them one ray at a time (prim/shapes_lone.hpp) and returns true to stop the walk.
  template <BoxTest kTest, bool kHybrid, class Limit, class Leaf, class Alone>
  [[gnu::always_inline]] static void walk_lanes(const Shapes& sh, const Ray& r, const M& lanes,
                                                Limit& limit, Leaf& leaf, Alone& alone,
                                                int lone) noexcept {
    Stack st;
    std::int32_t child = 0;
    unsigned count = 0;
    M mask = lanes;
    const B widen(T(1) + kWiden);
    for (;;) {
      bool few = false;
      if constexpr (kHybrid) few = __builtin_popcount(lane_bits(mask)) <= lone;
      if (few) {
        if (alone(child, count, mask)) return;
      } else if (count == 0) {
        // The children are not prefetched here (the frustum walk's are): incoherent packets ran
        // slower with it (docs/notebook/2026-11-incoherent-rays.md).
        const Wide& n = sh.wide[std::size_t(child)];
        const B lim_w = limit() * widen;
        M m[kW];
        B t0[kW];
        unsigned met = 0;
        for (int k = 0; k < kW; ++k) {
          m[k] = child_lanes<kTest>(n, k, r, mask, lim_w, t0[k]);
          met |= unsigned(xsimd::any(m[k])) << k;
        }
        met &= (1u << n.arity) - 1;
        if (met != 0) {
          st.descend(n, r.code, met, m, t0, child, count, mask);
          continue;
        }
      } else if (leaf(std::uint32_t(child), count, mask)) {
        return;
      }
      if (!st.pop([&] { return limit() * widen; }, child, count, mask)) return;
    }
  }

  // A leaf's triangle (col: its column of the leaf's rows, &Leaf::v[0][k]): its hit t beyond eps
  // for the lanes of `at` (infinity elsewhere, and where it misses), by the reference's
  // watertight formula.
  // Not forced inline: forced into every walk's leaf loop it ran some 4% slower at width 16
  // (AVX-512), and the camera groups' loop grew; GCC inlines it where the walk is small (the
  // shadow rays' frustum walk).
  static B triangle_t(const T* col, const Ray& r, const M& at, const B& eps) noexcept {
    constexpr int kRow = Shapes::kLeafItems;  // the distance between a column's coordinates
    V a, b, c;
    if (r.uniform) {
      auto vertex = [&](const T* p) {
        return V{B(p[r.row_x]) - r.o_perm.x, B(p[r.row_y]) - r.o_perm.y,
                 B(p[r.row_z]) - r.o_perm.z};
      };
      a = vertex(col), b = vertex(col + 3 * kRow), c = vertex(col + 6 * kRow);
    } else {
      auto vertex = [&](const T* p) {
        return r.permuted(V{B(p[0]) - r.o.x, B(p[kRow]) - r.o.y, B(p[2 * kRow]) - r.o.z});
      };
      a = vertex(col), b = vertex(col + 3 * kRow), c = vertex(col + 6 * kRow);
    }
    const B inf(std::numeric_limits<T>::infinity());
    prim::TriangleEdges<B> e = prim::triangle_uvw<T>(a, b, c, r.sx, r.sy);
    const M inside = at & prim::triangle_inside(e);
    if (!xsimd::any(inside)) return inf;
    prim::triangle_depth(e, a, b, c, r.sz);
    const B t = prim::triangle_t(e);
    return xsimd::select(inside & (t > eps), t, inf);
  }
};

}  // namespace lancer::packet
