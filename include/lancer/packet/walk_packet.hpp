// The packet walk of the bounded primitives' hierarchy (lancer/bvh.hpp), apart from the primitive
// tests: the caller's leaf functor tests the primitives of a leaf for the lanes whose ray meets
// its box. The base of the walks (walk_one_ray.hpp, tile_intervals.hpp, walk_camera.hpp; the
// whole: traversal.hpp). Include only from code built for the batch's ISA.
//
// Closest hit: the packet visits a wide node's children in the order of the binary splits it was
// collapsed from, the nearer side first by its summed direction's sign on each split's axis, and
// re-culls popped subtrees against the lanes' best t. The result does not depend on the order:
// the leaf functor keeps the lexicographic minimum of (t, object id).
// Any hit: children in their FIXED slot order, depth first, for every packet and ray,
// so each lane meets the objects along its segment in one order on every path (a product of
// transmittances over them is then the same bits everywhere). Stops once no lane is pending.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <type_traits>
#include <xsimd/xsimd.hpp>

#include "lancer/bvh.hpp"
#include "lancer/packet/fused.hpp"
#include "lancer/packet/lanes.hpp"
#include "lancer/vec3.hpp"

namespace lancer::packet {

template <class Arch, class T>
struct PacketWalk {
  using B = xsimd::batch<T, Arch>;
  using M = xsimd::batch_bool<T, Arch>;
  using V = Vec3<B>;
  using Node = typename Bvh<T>::Node;

  // The slab test's form of a ray: t = lo * inv - o * inv, one fused operation per plane. A zero
  // (or tiny) direction component becomes 2^-64: the reciprocal stays finite, so no 0 * inf NaN,
  // and every product stays below FLT_MAX for the loader's coordinates (|x| <= 1e18).
  // pad: per axis, how far (in t) each slab widens for this ray (kPadded traversals only).
  // neg[a]: every live lane's reciprocal on axis a is negative (meaningful only where
  // same_signs() says every live lane agrees on every axis).
  struct Ray {
    V inv, oi, pad;
    bool neg[3];
    std::size_t near[3], far[3];  // signed: byte offsets in a Node of each axis' lo or hi array
  };
  // Sets r's slab form of the ray (o, d), and its pad if kPad (only padded traversals read it;
  // the per-packet walks compute it anyway: without it GCC's any-hit code for width 8 changed
  // and tripped qemu 7.2's AVX2 emulation on random scene 109 of .ci/qemu.sh, as noted in
  // docs/precision.md).
  template <bool kPad>
  static void slab_ray(Ray& r, const V& o, const V& d) noexcept {
    const B tiny(T(0x1p-64));
    auto rcp = [&](const B& x) { return B(T(1)) / xsimd::select(xsimd::abs(x) < tiny, tiny, x); };
    r.inv = V{rcp(d.x), rcp(d.y), rcp(d.z)};
    r.oi = V{o.x * r.inv.x, o.y * r.inv.y, o.z * r.inv.z};
    if constexpr (kPad) {
      // Rays from beyond the origin limit (hits on a far plane): the sphere test's rounding
      // grows with |origin|, so the boxes grow by Bvh::kOriginPad |origin| for them.
      const B far = xsimd::max(xsimd::max(xsimd::abs(o.x), xsimd::abs(o.y)), xsimd::abs(o.z)) *
                    B(T(Bvh<T>::kOriginPad));
      r.pad = V{far * xsimd::abs(r.inv.x), far * xsimd::abs(r.inv.y), far * xsimd::abs(r.inv.z)};
    }
  }

  // Whether the live lanes' reciprocals agree in sign on every axis (coherent packets: camera
  // tiles off the image's centre lines); sets r.neg then.
  static bool same_signs(Ray& r, const M& valid) noexcept {
    const B zero(T(0));
    const B* inv[3] = {&r.inv.x, &r.inv.y, &r.inv.z};
    for (int a = 0; a < 3; ++a) {
      const M neg = *inv[a] < zero;
      if (xsimd::all(neg | !valid))
        r.neg[a] = true;
      else if (!xsimd::any(neg & valid))
        r.neg[a] = false;
      else
        return false;
    }
    set_planes(r);
    return true;
  }
  // r.near and r.far from r.neg.
  static void set_planes(Ray& r) noexcept {
    const std::size_t lo[3] = {offsetof(Node, lo_x), offsetof(Node, lo_y), offsetof(Node, lo_z)};
    const std::size_t hi[3] = {offsetof(Node, hi_x), offsetof(Node, hi_y), offsetof(Node, hi_z)};
    for (int a = 0; a < 3; ++a) {
      r.near[a] = r.neg[a] ? hi[a] : lo[a];
      r.far[a] = r.neg[a] ? lo[a] : hi[a];
    }
  }
  // same_signs' test over several packets: per axis a, neg[a] collects (as lane bits) the live
  // lanes whose reciprocal is negative, pos[a] those whose is not.
  static void add_signs(const Ray& r, unsigned live, unsigned* neg, unsigned* pos) noexcept {
    const B zero(T(0));
    const unsigned x = lane_bits(r.inv.x < zero), y = lane_bits(r.inv.y < zero),
                   z = lane_bits(r.inv.z < zero);
    neg[0] |= x & live, neg[1] |= y & live, neg[2] |= z & live;
    pos[0] |= ~x & live, pos[1] |= ~y & live, pos[2] |= ~z & live;
  }

  // add_signs' result as one code: bit a set where the lanes' reciprocal is negative on axis a,
  // or kMixedSigns where some axis has lanes of both signs.
  static constexpr unsigned kMixedSigns = 8;
  static unsigned sign_code(const unsigned* neg, const unsigned* pos) noexcept {
    if ((neg[0] && pos[0]) || (neg[1] && pos[1]) || (neg[2] && pos[2])) return kMixedSigns;
    return unsigned(neg[0] != 0) | unsigned(neg[1] != 0) << 1 | unsigned(neg[2] != 0) << 2;
  }
  // r's slab form for the sign code (not kMixedSigns) `code`.
  static void set_signs(Ray& r, unsigned code) noexcept {
    for (int a = 0; a < 3; ++a) r.neg[a] = (code >> a & 1u) != 0;
    set_planes(r);
  }

  // How a traversal tests boxes: padded for rays from beyond the origin limit; signed where
  // every live lane agrees on the direction's signs: each slab's near plane is then known per
  // packet (lo * inv <= hi * inv for inv > 0, rounding being monotonic: the same values as
  // generic's min and max), so no min/max per plane.
  enum class Slab { generic, padded, signed_ };

  // The lanes of `active` whose ray meets child k's box within [0, tmax]; tnear: where it enters.
  template <Slab kSlab>
  [[gnu::always_inline]] static M child_hit(const Node& n, int k, const Ray& r, const M& active,
                                            const B& tmax, B& tnear) noexcept {
    if constexpr (kSlab == Slab::signed_)
      return signed_hit(n, k, r.near, r.far, r, active, tmax, tnear);
    const B x0 = fmsub(B(n.lo_x[k]), r.inv.x, r.oi.x), x1 = fmsub(B(n.hi_x[k]), r.inv.x, r.oi.x);
    const B y0 = fmsub(B(n.lo_y[k]), r.inv.y, r.oi.y), y1 = fmsub(B(n.hi_y[k]), r.inv.y, r.oi.y);
    const B z0 = fmsub(B(n.lo_z[k]), r.inv.z, r.oi.z), z1 = fmsub(B(n.hi_z[k]), r.inv.z, r.oi.z);
    B nx = xsimd::min(x0, x1), ny = xsimd::min(y0, y1), nz = xsimd::min(z0, z1);
    B fx = xsimd::max(x0, x1), fy = xsimd::max(y0, y1), fz = xsimd::max(z0, z1);
    if constexpr (kSlab == Slab::padded) {
      nx = nx - r.pad.x, ny = ny - r.pad.y, nz = nz - r.pad.z;
      fx = fx + r.pad.x, fy = fy + r.pad.y, fz = fz + r.pad.z;
    }
    return overlap(nx, ny, nz, fx, fy, fz, active, tmax, tnear);
  }
  // child_hit's signed form, the planes at byte offsets near and far in a Node (a Ray's, or one
  // set for every packet of a camera block).
  [[gnu::always_inline]] static M signed_hit(const Node& n, int k, const std::size_t* near,
                                             const std::size_t* far, const Ray& r, const M& active,
                                             const B& tmax, B& tnear) noexcept {
    const char* base = reinterpret_cast<const char*>(&n) + std::size_t(k) * sizeof(T);
    auto plane = [&](std::size_t off) { return B(*reinterpret_cast<const T*>(base + off)); };
    const B nx = fmsub(plane(near[0]), r.inv.x, r.oi.x), fx = fmsub(plane(far[0]), r.inv.x, r.oi.x);
    const B ny = fmsub(plane(near[1]), r.inv.y, r.oi.y), fy = fmsub(plane(far[1]), r.inv.y, r.oi.y);
    const B nz = fmsub(plane(near[2]), r.inv.z, r.oi.z), fz = fmsub(plane(far[2]), r.inv.z, r.oi.z);
    return overlap(nx, ny, nz, fx, fy, fz, active, tmax, tnear);
  }
  // The lanes of `active` whose slabs (entered at n*, left at f*) overlap within [0, tmax];
  // tnear: where they enter.
  [[gnu::always_inline]] static M overlap(const B& nx, const B& ny, const B& nz, const B& fx,
                                          const B& fy, const B& fz, const M& active, const B& tmax,
                                          B& tnear) noexcept {
    tnear = xsimd::max(xsimd::max(nx, ny), xsimd::max(nz, B(T(0))));
    const B tfar = xsimd::min(xsimd::min(fx, fy), xsimd::min(fz, tmax));
    return active & (tnear <= tfar);
  }
  // How a packet from origins o traverses: 0 as built, 1 with boxes padded per lane, 2 not at
  // all (some lane beyond Bvh::kFarLimit, where the slab products could overflow: the caller
  // loops over all spheres instead).
  static int reach(const Bvh<T>& h, const M& valid, const V& o) noexcept {
    const B m = xsimd::max(xsimd::max(xsimd::abs(o.x), xsimd::abs(o.y)), xsimd::abs(o.z));
    if (!xsimd::any(valid & (m > B(h.origin_limit)))) return 0;
    return xsimd::any(valid & (m > B(T(Bvh<T>::kFarLimit)))) ? 2 : 1;
  }

  // The direction code of a packet (docs/accel.md): bit a set where the lanes' summed
  // direction goes up axis a. It orders a closest-hit traversal's children only.
  static unsigned direction_code(const M& valid, const V& d) noexcept {
    return unsigned(lanes_sum_up(valid, d.x)) | unsigned(lanes_sum_up(valid, d.y)) << 1 |
           unsigned(lanes_sum_up(valid, d.z)) << 2;
  }

  // The subtrees still to visit, with the lanes that met each one's box and where they entered
  // it.
  struct Stack {
    std::int32_t child[Bvh<T>::kStack], count[Bvh<T>::kStack];
    M mask[Bvh<T>::kStack];
    B tnear[Bvh<T>::kStack];
    int sp = 0;
  };

  // The children of n met by the lanes of `mask` within tmax, taken in `order` (slots,
  // Bvh::kOrderBits each): the first becomes (child, count, mask), the node to descend into; the
  // others go onto the stack, the last first, so that they pop in order. False when none is met.
  // Branches rather than masks: coherent packets meet the same children from node to node, and
  // a predicted branch lets the next node's load start before these tests end.
  //
  // Inlined into the closest-hit walk (its ray then stays in registers from node to node: 3.7%
  // more camera rays per second at 65536 spheres, median of 20 alternated runs). Out of line
  // (descend) for the any-hit walk, which `occluded` inlines into every render's shading loop:
  // inlined there too, it added 2-3% instructions to the course scenes at width 8 (out of line,
  // 0.6%). Left to GCC's choice, the counts were as before, but that code tripped qemu 7.2's AVX2
  // emulation (random scene 109 of PacketIdentity.RandomScenes under .ci/qemu.sh).
  template <Slab kSlab>
  [[gnu::always_inline]] static bool descend_inline(const Node& n, unsigned order, const Ray& r,
                                                    M& mask, const B& tmax, Stack& st,
                                                    std::int32_t& child,
                                                    std::int32_t& count) noexcept {
    constexpr int kW = Bvh<T>::kWidth;
    M m[kW];
    B tn[kW];
    int slot[kW];
    unsigned met = 0;
    for (int p = 0; p < kW; ++p) {
      slot[p] = int(order >> (Bvh<T>::kOrderBits * p)) & (kW - 1);
      m[p] = child_hit<kSlab>(n, slot[p], r, mask, tmax, tn[p]);
      met |= unsigned(xsimd::any(m[p])) << p;
    }
    met &= (1u << n.arity) - 1;  // the slots in use come first in every order
#pragma GCC unroll 8
    for (int p = 0; p < kW; ++p) {
      if (!(met >> p & 1)) continue;
#pragma GCC unroll 7
      for (int q = kW - 1; q > p; --q) {
        if (!(met >> q & 1)) continue;
        const int i = st.sp++;
        st.child[i] = n.child[slot[q]], st.count[i] = n.count[slot[q]];
        st.mask[i] = m[q], st.tnear[i] = tn[q];
      }
      child = n.child[slot[p]], count = n.count[slot[p]], mask = m[p];
      return true;
    }
    return false;
  }
  template <Slab kSlab>
  [[gnu::noinline]] static bool descend(const Node& n, unsigned order, const Ray& r, M& mask,
                                        const B& tmax, Stack& st, std::int32_t& child,
                                        std::int32_t& count) noexcept {
    return descend_inline<kSlab>(n, order, r, mask, tmax, st, child, count);
  }

  // No one-ray step: the packet walks every node with its lanes (the step is never called).
  struct PacketsOnly {
    static constexpr int kMaxLanes = 0;
  };

  // leaf(first, count, mask): tests leaf-order spheres [first, first + count) for `mask`,
  // lowering best_t (read here to cull). one(lanes, child, count): where at most
  // one.limit lanes go on into a subtree, walks it for each of them alone, lowering best_t
  // (the hybrid traversal of Benthin et al.).
  template <bool kPadded, class Leaf, class One = PacketsOnly>
  static void closest(const Bvh<T>& h, const M& valid, const V& o, const V& d, const B& best_t,
                      Leaf&& leaf, One&& one = One{}) noexcept {
    Ray r;
    slab_ray<true>(r, o, d);
    if constexpr (kPadded)
      closest_with<Slab::padded>(h, valid, r, d, best_t, leaf, one);
    else if (same_signs(r, valid))
      closest_with<Slab::signed_>(h, valid, r, d, best_t, leaf, one);
    else
      closest_with<Slab::generic>(h, valid, r, d, best_t, leaf, one);
  }

  // leaf(first, count, mask) -> the lanes still pending after that leaf (of `mask`'s and the
  // others). Returns the lanes of `valid` still pending at the end. one(lanes, child, count,
  // pending) -> pending: where at most one.limit pending lanes go on into a subtree, walks it
  // for each of them alone.
  template <bool kPadded, class Leaf, class One = PacketsOnly>
  static M any(const Bvh<T>& h, const M& valid, const V& o, const V& d, const B& tmax, Leaf&& leaf,
               One&& one = One{}) noexcept {
    Ray r;
    slab_ray<true>(r, o, d);
    if constexpr (kPadded)
      return any_with<Slab::padded>(h, valid, r, tmax, leaf, one);
    else if (same_signs(r, valid))
      return any_with<Slab::signed_>(h, valid, r, tmax, leaf, one);
    else
      return any_with<Slab::generic>(h, valid, r, tmax, leaf, one);
  }

  template <Slab kSlab, class Leaf>
  static void closest_with(const Bvh<T>& h, const M& valid, const Ray& r, const V& d,
                           const B& best_t, Leaf& leaf) noexcept {
    PacketsOnly none;
    closest_with<kSlab>(h, valid, r, d, best_t, leaf, none);
  }
  template <Slab kSlab, class Leaf, class One>
  static void closest_with(const Bvh<T>& h, const M& valid, const Ray& r, const V& d,
                           const B& best_t, Leaf& leaf, One& one) noexcept {
    // Signed: every lane goes the same way along each axis; else the lanes' summed direction.
    const unsigned code = kSlab == Slab::signed_ ? unsigned(!r.neg[0]) | unsigned(!r.neg[1]) << 1 |
                                                       unsigned(!r.neg[2]) << 2
                                                 : direction_code(valid, d);
    closest_from<kSlab>(h, valid, r, code, 0, best_t, leaf, one);
  }
  // closest_with's walk of the subtree of inner node `start` (0: the whole hierarchy), children
  // in the order of direction code `code`.
  template <Slab kSlab, class Leaf, class One>
  static void closest_from(const Bvh<T>& h, const M& valid, const Ray& r, unsigned code,
                           std::int32_t start, const B& best_t, Leaf& leaf, One& one) noexcept {
    Stack st;
    std::int32_t child = start, count = -1;
    M mask = valid;
    for (;;) {
      if constexpr (One::kMaxLanes > 0) {
        if (const unsigned lanes = lane_bits(mask); __builtin_popcount(lanes) <= one.limit) {
          one(lanes, child, count);
          goto next;
        }
      } else if (false) {
        goto next;  // packets only: the label stays used (no -Wunused-label), the code is dead
      }
      if (count < 0) {
        const Node& n = h.nodes[std::size_t(child)];
        if (descend_inline<kSlab>(n, unsigned(n.order[code]), r, mask, best_t, st, child, count))
          continue;
      } else {
        leaf(child, count, mask);
      }
    next:
      for (;;) {  // the next subtree some lane may still find a nearer hit in
        if (st.sp == 0) return;
        const int i = --st.sp;
        mask = st.mask[i] & (st.tnear[i] <= best_t);
        if (xsimd::any(mask)) {
          child = st.child[i], count = st.count[i];
          break;
        }
      }
    }
  }

  template <Slab kSlab, class Leaf, class One>
  static M any_with(const Bvh<T>& h, const M& valid, const Ray& r, const B& tmax, Leaf& leaf,
                    One& one) noexcept {
    Stack st;
    std::int32_t child = 0, count = -1;
    M pending = valid, mask = valid;
    for (;;) {
      if constexpr (One::kMaxLanes > 0) {
        if (const unsigned lanes = lane_bits(mask); __builtin_popcount(lanes) <= one.limit) {
          pending = one(lanes, child, count, pending);
          if (!xsimd::any(pending)) return pending;
          goto next;
        }
      } else if (false) {
        goto next;  // as in closest_with
      }
      if (count < 0) {
        if (descend<kSlab>(h.nodes[std::size_t(child)], Bvh<T>::kSlotOrder, r, mask, tmax, st,
                           child, count))
          continue;
      } else {
        pending = leaf(child, count, mask, pending);
        if (!xsimd::any(pending)) return pending;
      }
    next:
      for (;;) {
        if (st.sp == 0) return pending;
        const int i = --st.sp;
        mask = st.mask[i] & pending;
        if (xsimd::any(mask)) {
          child = st.child[i], count = st.count[i];
          break;
        }
      }
    }
  }

  // ---- reductions over a packet's live lanes ----------------------------------------------
  using F4 = __m128;
  // The least (kMax: greatest) of get(i)'s lanes over the live lanes of kN packets, in every
  // lane of a 4-float register: the packets folded lane by lane, then the register's halves,
  // then two shuffles (once per block, and after each leaf).
  template <bool kMax, int kN, class Get>
  static F4 lane_bound(const M* valid, Get get) noexcept {
    constexpr T fill =
        kMax ? -std::numeric_limits<T>::infinity() : std::numeric_limits<T>::infinity();
    B v(fill);
    for (int i = 0; i < kN; ++i) {
      const B x = xsimd::select(valid[i], get(i), B(fill));
      v = kMax ? xsimd::max(v, x) : xsimd::min(v, x);
    }
    return reduce<kMax>(v);
  }
  // The least (kMax: greatest) of v's lanes, in every lane of a 4-float register.
  template <bool kMax>
  static F4 reduce(const B& v) noexcept {
    auto op = [](F4 a, F4 b) { return kMax ? _mm_max_ps(a, b) : _mm_min_ps(a, b); };
    F4 m;
    if constexpr (B::size == 16) {
      const __m512 z = v;
      const __m256 lo = _mm512_castps512_ps256(z);
      const __m256 hi = _mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(z), 1));
      m = op(op(_mm256_castps256_ps128(lo), _mm256_extractf128_ps(lo, 1)),
             op(_mm256_castps256_ps128(hi), _mm256_extractf128_ps(hi, 1)));
    } else if constexpr (B::size == 8) {
      const __m256 y = v;
      m = op(_mm256_castps256_ps128(y), _mm256_extractf128_ps(y, 1));
    } else {
      m = v;
    }
    m = op(m, _mm_shuffle_ps(m, m, _MM_SHUFFLE(2, 3, 0, 1)));
    return op(m, _mm_shuffle_ps(m, m, _MM_SHUFFLE(1, 0, 3, 2)));
  }

  // The greatest of x's live lanes less the least (valid: some lane live).
  static T live_span(const M& valid, const B& x) noexcept {
    if constexpr (std::is_same_v<T, float>) {
      const M v[1] = {valid};
      auto get = [&](int) { return x; };
      return _mm_cvtss_f32((lane_bound<true, 1>(v, get))) -
             _mm_cvtss_f32((lane_bound<false, 1>(v, get)));
    } else {  // double: lane by lane (once per secondary packet)
      constexpr T inf = std::numeric_limits<T>::infinity();
      alignas(64) T hi[B::size], lo[B::size];
      xsimd::select(valid, x, B(-inf)).store_aligned(hi);
      xsimd::select(valid, x, B(inf)).store_aligned(lo);
      T h = -inf, l = inf;
      for (std::size_t k = 0; k < B::size; ++k) h = std::max(h, hi[k]), l = std::min(l, lo[k]);
      return h - l;
    }
  }
};

}  // namespace lancer::packet
