// Packet traversal of the sphere hierarchy (lancer/bvh.hpp), apart from the primitive tests: the
// caller's leaf functor tests the spheres of a leaf for the lanes whose ray meets its box.
// Include only from packet/kernel.hpp (code built for the batch's ISA).
//
// Closest hit: the packet visits a wide node's children in the order of the binary splits it was
// collapsed from, the nearer side first by its summed direction's sign on each split's axis, and
// re-culls popped subtrees against the lanes' best t. The result does not depend on the order:
// the leaf functor keeps the lexicographic minimum of (t, object id).
// Any hit: children in their FIXED slot order, depth first, for every packet and ray,
// so each lane meets the objects along its segment in one order on every path (a product of
// transmittances over them is then the same bits everywhere). Stops once no lane is pending.
#pragma once

#include <cstddef>
#include <cstdint>
#include <xsimd/xsimd.hpp>

#include "lancer/bvh.hpp"
#include "lancer/packet/fused.hpp"
#include "lancer/vec3.hpp"

namespace lancer::packet {

template <class Arch, class T>
struct Traversal {
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
  static Ray slab_ray(const V& o, const V& d) noexcept {
    const B tiny(T(0x1p-64));
    auto rcp = [&](const B& x) { return B(T(1)) / xsimd::select(xsimd::abs(x) < tiny, tiny, x); };
    Ray r;
    r.inv = V{rcp(d.x), rcp(d.y), rcp(d.z)};
    r.oi = V{o.x * r.inv.x, o.y * r.inv.y, o.z * r.inv.z};
    // Rays from beyond the origin limit (hits on a far plane): the sphere test's rounding
    // grows with |origin|, so the boxes grow by Bvh::kOriginPad |origin| for them.
    const B far = xsimd::max(xsimd::max(xsimd::abs(o.x), xsimd::abs(o.y)), xsimd::abs(o.z)) *
                  B(T(Bvh<T>::kOriginPad));
    r.pad = V{far * xsimd::abs(r.inv.x), far * xsimd::abs(r.inv.y), far * xsimd::abs(r.inv.z)};
    return r;
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
    const std::size_t lo[3] = {offsetof(Node, lo_x), offsetof(Node, lo_y), offsetof(Node, lo_z)};
    const std::size_t hi[3] = {offsetof(Node, hi_x), offsetof(Node, hi_y), offsetof(Node, hi_z)};
    for (int a = 0; a < 3; ++a) {
      r.near[a] = r.neg[a] ? hi[a] : lo[a];
      r.far[a] = r.neg[a] ? lo[a] : hi[a];
    }
    return true;
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
    B nx, ny, nz, fx, fy, fz;
    if constexpr (kSlab == Slab::signed_) {
      const char* base = reinterpret_cast<const char*>(&n) + std::size_t(k) * sizeof(T);
      auto plane = [&](std::size_t off) { return B(*reinterpret_cast<const T*>(base + off)); };
      nx = fmsub(plane(r.near[0]), r.inv.x, r.oi.x), fx = fmsub(plane(r.far[0]), r.inv.x, r.oi.x);
      ny = fmsub(plane(r.near[1]), r.inv.y, r.oi.y), fy = fmsub(plane(r.far[1]), r.inv.y, r.oi.y);
      nz = fmsub(plane(r.near[2]), r.inv.z, r.oi.z), fz = fmsub(plane(r.far[2]), r.inv.z, r.oi.z);
    } else {
      const B x0 = fmsub(B(n.lo_x[k]), r.inv.x, r.oi.x), x1 = fmsub(B(n.hi_x[k]), r.inv.x, r.oi.x);
      const B y0 = fmsub(B(n.lo_y[k]), r.inv.y, r.oi.y), y1 = fmsub(B(n.hi_y[k]), r.inv.y, r.oi.y);
      const B z0 = fmsub(B(n.lo_z[k]), r.inv.z, r.oi.z), z1 = fmsub(B(n.hi_z[k]), r.inv.z, r.oi.z);
      nx = xsimd::min(x0, x1), ny = xsimd::min(y0, y1), nz = xsimd::min(z0, z1);
      fx = xsimd::max(x0, x1), fy = xsimd::max(y0, y1), fz = xsimd::max(z0, z1);
    }
    if constexpr (kSlab == Slab::padded) {
      nx = nx - r.pad.x, ny = ny - r.pad.y, nz = nz - r.pad.z;
      fx = fx + r.pad.x, fy = fy + r.pad.y, fz = fz + r.pad.z;
    }
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
    // Pairwise sums through memory (xsimd 8.1's AVX-512 hadd needs AVX512DQ): log2(W) steps.
    alignas(64) T lanes[3][B::size];
    const B* axes[3] = {&d.x, &d.y, &d.z};
    unsigned code = 0;
    for (int a = 0; a < 3; ++a) {
      xsimd::select(valid, *axes[a], B(T(0))).store_aligned(lanes[a]);
      for (std::size_t w = B::size / 2; w > 0; w /= 2)
        for (std::size_t k = 0; k < w; ++k) lanes[a][k] += lanes[a][k + w];
      code |= unsigned(lanes[a][0] >= T(0)) << a;
    }
    return code;
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

  // leaf(first, count, mask): tests leaf-order spheres [first, first + count) for `mask`,
  // lowering best_t (read here to cull).
  template <bool kPadded, class Leaf>
  static void closest(const Bvh<T>& h, const M& valid, const V& o, const V& d, const B& best_t,
                      Leaf&& leaf) noexcept {
    Ray r = slab_ray(o, d);
    if constexpr (kPadded)
      closest_with<Slab::padded>(h, valid, r, d, best_t, leaf);
    else if (same_signs(r, valid))
      closest_with<Slab::signed_>(h, valid, r, d, best_t, leaf);
    else
      closest_with<Slab::generic>(h, valid, r, d, best_t, leaf);
  }

  // leaf(first, count, mask) -> the lanes still pending after that leaf (of `mask`'s and the
  // others). Returns the lanes of `valid` still pending at the end.
  template <bool kPadded, class Leaf>
  static M any(const Bvh<T>& h, const M& valid, const V& o, const V& d, const B& tmax,
               Leaf&& leaf) noexcept {
    Ray r = slab_ray(o, d);
    if constexpr (kPadded)
      return any_with<Slab::padded>(h, valid, r, tmax, leaf);
    else if (same_signs(r, valid))
      return any_with<Slab::signed_>(h, valid, r, tmax, leaf);
    else
      return any_with<Slab::generic>(h, valid, r, tmax, leaf);
  }

 private:
  template <Slab kSlab, class Leaf>
  static void closest_with(const Bvh<T>& h, const M& valid, const Ray& r, const V& d,
                           const B& best_t, Leaf& leaf) noexcept {
    // Signed: every lane goes the same way along each axis; else the lanes' summed direction.
    const unsigned code = kSlab == Slab::signed_ ? unsigned(!r.neg[0]) | unsigned(!r.neg[1]) << 1 |
                                                       unsigned(!r.neg[2]) << 2
                                                 : direction_code(valid, d);
    Stack st;
    std::int32_t child = 0, count = -1;
    M mask = valid;
    for (;;) {
      if (count < 0) {
        const Node& n = h.nodes[std::size_t(child)];
        if (descend_inline<kSlab>(n, unsigned(n.order[code]), r, mask, best_t, st, child, count))
          continue;
      } else {
        leaf(child, count, mask);
      }
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

  template <Slab kSlab, class Leaf>
  static M any_with(const Bvh<T>& h, const M& valid, const Ray& r, const B& tmax,
                    Leaf& leaf) noexcept {
    Stack st;
    std::int32_t child = 0, count = -1;
    M pending = valid, mask = valid;
    for (;;) {
      if (count < 0) {
        if (descend<kSlab>(h.nodes[std::size_t(child)], Bvh<T>::kSlotOrder, r, mask, tmax, st,
                           child, count))
          continue;
      } else {
        pending = leaf(child, count, mask, pending);
        if (!xsimd::any(pending)) return pending;
      }
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
};

}  // namespace lancer::packet
