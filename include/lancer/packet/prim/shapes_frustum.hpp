// A coherent packet's walk of the shapes' wide hierarchy with frustum culling (Wald et al.): a
// node's four children are first tested once for the whole packet, against bounds of its lanes'
// rays, in one register of four T (prim/shapes_lone.hpp's), and only the children that test
// lets in get the per-lane test (shapes_walk.hpp's child_lanes). Camera rays, a flat mirror's
// rays and shadow rays towards a light share most nodes; where a tile's lanes part near the
// leaves (triangles smaller than its pixels), most children are turned away by the one test.
// The per-lane test stays: the frustum alone accepts the room between the rays, and each lane
// would then test triangles it cannot reach (on sub-pixel triangles, twice the leaf work).
//
// The bounds are interval arithmetic on the slab form (plane - o_near) * inv: an axis's entry is
// bounded below by the plane minus the greatest (d up) or least (d down) o_near, times the
// least or greatest 1 / d, whichever product is lower; the exit above, alike. Rounding to
// nearest is monotonic, so each bound computed in T bounds every lane's value of that form,
// which the walk's margins make a conservative test (shapes_walk.hpp's header) as they do the
// fused form the per-lane test computes (plane * inv - o_near inv): a box the frustum turns away
// holds no hit of the reference for any lane, and the closest hit, the least (t, primitive), is
// unchanged.
// Include only from code built for the batch's ISA (packet/kernel.hpp).
#pragma once

#include <algorithm>
#include <cstdint>
#include <limits>

#include "lancer/packet/lanes.hpp"
#include "lancer/packet/prim/shapes_lone.hpp"
#include "lancer/packet/prim/shapes_walk.hpp"
#include "lancer/shapes.hpp"

namespace lancer::packet {

// What the camera groups tell a counter (lancer profile's shape groups; ShapePackets::closest_
// square and walk_group): the default counts nothing and compiles to nothing.
template <class M>
struct NoGroupCount {
  void group(unsigned /*live*/) const noexcept {}
  void walk() const noexcept {}
  void tiles_alone(unsigned /*tiles*/) const noexcept {}
  void node() const noexcept {}
  void box_test() const noexcept {}
  void leaf(const M* /*at*/, unsigned /*packets*/) const noexcept {}
};

template <class Arch, class T>
struct ShapeFrustum {
  using Packet = ShapeWalk<Arch, T>;
  using B = typename Packet::B;
  using M = typename Packet::M;
  using Ray = typename Packet::Ray;
  using Shapes = PreparedShapes<T>;
  using Wide = typename Shapes::WideNode;
  using C = typename ShapeLone<Arch, T>::C;
  using CM = typename ShapeLone<Arch, T>::CM;
  static constexpr int W = Packet::W;
  static constexpr int kC = static_cast<int>(C::size);
  static constexpr int kW = Shapes::kWide;
  static constexpr int kParts = kW / kC;
  static constexpr T kWiden = Packet::kWiden;
  static_assert(W % kC == 0);

  // Per axis, the bounds' operands: entry = (near plane - n_o) * n_i0 or * n_i1, the lower;
  // exit = (far plane - f_o) * the lower or the higher 1 / d, the higher.
  struct Bounds {
    T n_o[3], f_o[3], i_lo[3], i_hi[3];
    int near[3], far[3];

    Bounds() = default;
    // r: a packet with r.fast (one sign per axis over the lanes of `live`, none zero).
    Bounds(const Ray& r, const M& live) noexcept {
      const B inf(std::numeric_limits<T>::infinity());
      const B* on[3] = {&r.o_near.x, &r.o_near.y, &r.o_near.z};
      const B* of[3] = {&r.o_far.x, &r.o_far.y, &r.o_far.z};
      const B* iv[3] = {&r.inv.x, &r.inv.y, &r.inv.z};
      for (int a = 0; a < 3; ++a) {
        near[a] = r.near[a], far[a] = r.far[a];
        // Up (1 / d > 0): the entry grows with (plane - o), so its least is at the greatest o;
        // down: the opposite. The exit's greatest the other way round.
        const bool up = far[a] > near[a];
        n_o[a] = up ? -least(xsimd::select(live, -*on[a], inf))
                    : least(xsimd::select(live, *on[a], inf));
        f_o[a] = up ? least(xsimd::select(live, *of[a], inf))
                    : -least(xsimd::select(live, -*of[a], inf));
        i_lo[a] = least(xsimd::select(live, *iv[a], inf));
        i_hi[a] = -least(xsimd::select(live, -*iv[a], inf));
      }
    }
    // Widened to enclose o's bounds too (a packet with the same entry planes).
    void merge(const Bounds& o) noexcept {
      for (int a = 0; a < 3; ++a) {
        const bool up = far[a] > near[a];
        n_o[a] = up ? std::max(n_o[a], o.n_o[a]) : std::min(n_o[a], o.n_o[a]);
        f_o[a] = up ? std::min(f_o[a], o.f_o[a]) : std::max(f_o[a], o.f_o[a]);
        i_lo[a] = std::min(i_lo[a], o.i_lo[a]), i_hi[a] = std::max(i_hi[a], o.i_hi[a]);
      }
    }
    // The least lane of v: its registers of four (C) first, then their lanes.
    static T least(const B& v) noexcept {
      alignas(64) T x[W];
      v.store_aligned(x);
      C m = C::load_aligned(x);
      for (int c = kC; c < W; c += kC) m = xsimd::min(m, C::load_aligned(x + c));
      alignas(32) T y[kC];
      m.store_aligned(y);
      T r = y[0];
      for (int k = 1; k < kC; ++k) r = y[k] < r ? y[k] : r;
      return r;
    }
  };

  // The children of n (slot bits) the frustum may meet.
  static unsigned met_children(const Wide& n, const Bounds& f) noexcept {
    unsigned met = 0;
    const T* base = &n.lo_x[0];
    for (int h = 0; h < kParts; ++h) {
      auto plane = [&](int off) { return C::load_aligned(base + off + h * kC); };
      C t0(T(0)), t1(std::numeric_limits<T>::infinity());
      for (int a = 0; a < 3; ++a) {
        const C en = plane(f.near[a]) - C(f.n_o[a]);
        const C ex = plane(f.far[a]) - C(f.f_o[a]);
        const C lo(f.i_lo[a]), hi(f.i_hi[a]);
        t0 = xsimd::max(t0, xsimd::min(en * lo, en * hi));
        t1 = xsimd::min(t1, xsimd::max(ex * lo, ex * hi));
      }
      // The per-lane test's widening of the same values (monotonic, so the bounds hold).
      t0 = t0 * C(T(1) - kWiden);
      const CM in = t0 <= t1 * C(T(1) + kWiden);
      met |= lane_bits(in) << (h * kC);
    }
    return met & ((1u << n.arity) - 1);
  }

  // Node n entered: its children's nodes or leaf records prefetched (all of them, before the
  // frustum's test: the loads start sooner), and the children the frustum, once made, may meet.
  [[gnu::always_inline]] static unsigned enter(const Shapes& sh, const Wide& n, const Bounds& f,
                                               bool have_f) noexcept {
    for (int k = 0; k < n.arity; ++k) Packet::prefetch(sh, n.child[k], n.count[k]);
    return have_f ? met_children(n, f) : (1u << n.arity) - 1;
  }

  // Packet::walk's visits for the lanes of `lanes` (a packet with r.fast), a node's children
  // tested by the frustum first: leaf(leaf index, count, lanes_at_leaf) returns true to stop. Out
  // of line: forced inline into its callers, with the children's loop unrolled, the 1M-triangle
  // mesh's primary rays lost what the frustum gains (width 16, AVX-512).
  template <class Limit, class Leaf>
  [[gnu::noinline]] static void walk(const Shapes& sh, const Ray& r, const M& lanes, Limit& limit,
                                     Leaf& leaf) noexcept {
    if (sh.wide.empty()) return;
    // Made once the root lets some lane in: a packet that misses every shape pays nothing.
    Bounds f;
    bool have_f = false;
    typename Packet::Stack st;
    std::int32_t child = 0;
    unsigned count = 0;
    M mask = lanes;
    const B widen(T(1) + kWiden);
    for (;;) {
      if (count == 0) {
        const Wide& n = sh.wide[std::size_t(child)];
        unsigned met = enter(sh, n, f, have_f);
        if (met != 0) {
          // The per-lane test on the children the frustum lets in.
          const B lim_w = limit() * widen;
          M m[kW];
          B tl[kW];
          for (unsigned b = met; b; b &= b - 1) {
            const int k = __builtin_ctz(b);
            m[k] = Packet::template child_lanes<Packet::BoxTest::fast>(n, k, r, mask, lim_w, tl[k]);
            if (!xsimd::any(m[k])) met &= ~(1u << k);
          }
          if (met != 0 && !have_f) f = Bounds(r, lanes), have_f = true;
          if (met != 0) {
            st.descend(n, r.code, met, m, tl, child, count, mask);
            continue;
          }
        }
      } else if (leaf(std::uint32_t(child), count, mask)) {
        return;
      }
      if (!st.pop([&] { return limit() * widen; }, child, count, mask)) return;
    }
  }

  // The packets of `live` (bits) that may walk together with its first fast one: those with
  // r.fast and its entry planes (direction signs); 0 when none is fast.
  static unsigned same_signs(const Ray* r, unsigned live) noexcept {
    unsigned fast = 0;
    for (unsigned p = live; p; p &= p - 1)
      fast |= unsigned(r[__builtin_ctz(p)].fast) << __builtin_ctz(p);
    if (fast == 0) return 0;
    const Ray& a = r[__builtin_ctz(fast)];
    unsigned same = 0;
    for (unsigned p = fast; p; p &= p - 1) {
      const Ray& b = r[__builtin_ctz(p)];
      if (b.near[0] == a.near[0] && b.near[1] == a.near[1] && b.near[2] == a.near[2])
        same |= 1u << __builtin_ctz(p);
    }
    return same;
  }

  // A group's subtrees still to visit: per packet (bits) its lanes and their entry t.
  template <int kN>
  struct GroupStack {
    std::int32_t child[Shapes::kWideStack];
    std::uint8_t count[Shapes::kWideStack];
    std::uint16_t packets[Shapes::kWideStack];
    M mask[Shapes::kWideStack][kN];
    B t0[Shapes::kWideStack][kN];
    int sp = 0;
  };

  // walk()'s visits for kN packets together (camera tiles side by side, each r[i] with r.fast
  // and the same signs: same_signs), whose lanes are lanes[i] for the packets of `live` (bits): one
  // frustum over all of them, then the per-lane test of each packet that reaches a child.
  // leaf(leaf index, count, masks, packets) returns true to stop; limit(i) is packet i's limit.
  // count_to: a NoGroupCount's interface, told of each node entered and per-lane box test.
  template <int kN, class Limit, class Leaf, class Count>
  [[gnu::noinline]] static void walk_group(const Shapes& sh, const Ray* r, const M* lanes,
                                           unsigned live, Limit& limit, Leaf& leaf,
                                           Count count_to) noexcept {
    static_assert(kN <= 16, "packets are bits of a 16-bit word");
    if (sh.wide.empty() || live == 0) return;
    Bounds f;
    bool have_f = false;
    GroupStack<kN> st;
    std::int32_t child = 0;
    unsigned count = 0, at = live;
    M mask[kN];
    for (unsigned p = live; p; p &= p - 1) mask[__builtin_ctz(p)] = lanes[__builtin_ctz(p)];
    const B widen(T(1) + kWiden);
    const unsigned code = r[__builtin_ctz(live)].code;
    for (;;) {
      if (count == 0) {
        const Wide& n = sh.wide[std::size_t(child)];
        unsigned met = enter(sh, n, f, have_f);
        count_to.node();
        if (met != 0) {
          B lim_w[kN];
          for (unsigned p = at; p; p &= p - 1)
            lim_w[__builtin_ctz(p)] = limit(__builtin_ctz(p)) * widen;
          M m[kW][kN];
          B tl[kW][kN];
          unsigned reach[kW];
          for (unsigned b = met; b; b &= b - 1) {
            const int k = __builtin_ctz(b);
            unsigned q = 0;
            for (unsigned p = at; p; p &= p - 1) {
              const int i = __builtin_ctz(p);
              m[k][i] = Packet::template child_lanes<Packet::BoxTest::fast>(n, k, r[i], mask[i],
                                                                            lim_w[i], tl[k][i]);
              count_to.box_test();
              q |= unsigned(xsimd::any(m[k][i])) << i;
            }
            reach[k] = q;
            if (q == 0) met &= ~(1u << k);
          }
          if (met != 0 && !have_f) {
            f = Bounds(r[__builtin_ctz(live)], lanes[__builtin_ctz(live)]);
            for (unsigned p = live & (live - 1); p; p &= p - 1)
              f.merge(Bounds(r[__builtin_ctz(p)], lanes[__builtin_ctz(p)]));
            have_f = true;
          }
          if (met != 0) {
            int slots[kW];
            const int c = Packet::near_first(n, code, met, slots);
            for (int q = c - 1; q > 0; --q) {
              const int k = slots[q];
              st.child[st.sp] = n.child[k], st.count[st.sp] = n.count[k];
              st.packets[st.sp] = std::uint16_t(reach[k]);
              for (unsigned p = reach[k]; p; p &= p - 1) {
                const int i = __builtin_ctz(p);
                st.mask[st.sp][i] = m[k][i], st.t0[st.sp][i] = tl[k][i];
              }
              ++st.sp;
            }
            const int k = slots[0];
            child = n.child[k], count = n.count[k], at = reach[k];
            for (unsigned p = at; p; p &= p - 1) mask[__builtin_ctz(p)] = m[k][__builtin_ctz(p)];
            continue;
          }
        }
      } else if (leaf(std::uint32_t(child), count, mask, at)) {
        return;
      }
      // The next subtree some packet's lane may still reach before its limit.
      for (at = 0; at == 0;) {
        if (st.sp == 0) return;
        --st.sp;
        for (unsigned p = st.packets[st.sp]; p; p &= p - 1) {
          const int i = __builtin_ctz(p);
          mask[i] = st.mask[st.sp][i] & (st.t0[st.sp][i] <= limit(i) * widen);
          at |= unsigned(xsimd::any(mask[i])) << i;
        }
      }
      child = st.child[st.sp], count = st.count[st.sp];
    }
  }
};

}  // namespace lancer::packet
