// Packet traversal of the sphere hierarchy (lancer/bvh.hpp), apart from the primitive tests: the
// caller's leaf functor tests the spheres of a leaf for the lanes whose ray meets its box.
// Include only from packet/kernel.hpp (code built for the batch's ISA).
//
// Closest hit: the packet visits a wide node's children in the order of the binary splits it was
// collapsed from, the nearer side first by its summed direction's sign on each split's axis, and
// re-culls popped subtrees against the lanes' best t. The result does not depend on the order:
// the leaf functor keeps the lexicographic minimum of (t, object id).
// Any hit: children in their FIXED slot order (0 to 3), depth first, for every packet and ray,
// so each lane meets the objects along its segment in one order on every path (a product of
// transmittances over them is then the same bits everywhere). Stops once no lane is pending.
#pragma once

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
  struct Ray {
    V inv, oi, pad;
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

  // The lanes of `active` whose ray meets child k's box within [0, tmax]; tnear: where it enters.
  template <bool kPadded>
  static M child_hit(const Node& n, int k, const Ray& r, const M& active, const B& tmax,
                     B& tnear) noexcept {
    const B x0 = fmsub(B(n.lo_x[k]), r.inv.x, r.oi.x), x1 = fmsub(B(n.hi_x[k]), r.inv.x, r.oi.x);
    const B y0 = fmsub(B(n.lo_y[k]), r.inv.y, r.oi.y), y1 = fmsub(B(n.hi_y[k]), r.inv.y, r.oi.y);
    const B z0 = fmsub(B(n.lo_z[k]), r.inv.z, r.oi.z), z1 = fmsub(B(n.hi_z[k]), r.inv.z, r.oi.z);
    B nx = xsimd::min(x0, x1), ny = xsimd::min(y0, y1), nz = xsimd::min(z0, z1);
    B fx = xsimd::max(x0, x1), fy = xsimd::max(y0, y1), fz = xsimd::max(z0, z1);
    if constexpr (kPadded) {
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
  // it. A wide node pushes its children met (at most 4) and the traversal pops the next.
  struct Stack {
    std::int32_t child[Bvh<T>::kStack], count[Bvh<T>::kStack];
    M mask[Bvh<T>::kStack];
    B tnear[Bvh<T>::kStack];
    int sp = 0;
  };

  // Pushes the children of n met by the lanes of `mask` within tmax, the slots in the order
  // `order` lists (2 bits each) last to first, so the first of the order is popped first.
  // Branch-free: every child is written, only those met advance the stack pointer.
  template <bool kPadded>
  static void push_children(const Node& n, unsigned order, const Ray& r, const M& mask,
                            const B& tmax, Stack& st) noexcept {
    M m[4];
    B tn[4];
    int slot[4];
    unsigned met = 0;
    for (int p = 0; p < 4; ++p) {
      slot[p] = int(order >> (2 * p)) & 3;
      m[p] = child_hit<kPadded>(n, slot[p], r, mask, tmax, tn[p]);
      met |= unsigned(xsimd::any(m[p])) << p;
    }
    met &= (1u << n.arity) - 1;  // the slots in use come first in every order
    for (int p = 3; p >= 0; --p) {
      const int i = st.sp;
      st.child[i] = n.child[slot[p]], st.count[i] = n.count[slot[p]];
      st.mask[i] = m[p], st.tnear[i] = tn[p];
      st.sp += int(met >> p) & 1;
    }
  }

  // leaf(first, count, mask): tests leaf-order spheres [first, first + count) for `mask`,
  // lowering best_t (read here to cull).
  template <bool kPadded, class Leaf>
  static void closest(const Bvh<T>& h, const M& valid, const V& o, const V& d, const B& best_t,
                      Leaf&& leaf) noexcept {
    const Ray r = slab_ray(o, d);
    const unsigned shift = 8 * direction_code(valid, d);
    Stack st;
    st.child[0] = 0, st.count[0] = -1, st.mask[0] = valid, st.tnear[0] = B(T(0));
    st.sp = 1;
    while (st.sp > 0) {  // the next subtree some lane may still find a nearer hit in
      const int i = --st.sp;
      const M mask = st.mask[i] & (st.tnear[i] <= best_t);
      if (!xsimd::any(mask)) continue;
      if (st.count[i] >= 0) {
        leaf(st.child[i], st.count[i], mask);
      } else {
        const Node& n = h.nodes[std::size_t(st.child[i])];
        push_children<kPadded>(n, unsigned(n.order >> shift) & 0xFF, r, mask, best_t, st);
      }
    }
  }

  // leaf(first, count, mask) -> the lanes still pending after that leaf (of `mask`'s and the
  // others). Returns the lanes of `valid` still pending at the end.
  template <bool kPadded, class Leaf>
  static M any(const Bvh<T>& h, const M& valid, const V& o, const V& d, const B& tmax,
               Leaf&& leaf) noexcept {
    const Ray r = slab_ray(o, d);
    Stack st;
    st.child[0] = 0, st.count[0] = -1, st.mask[0] = valid, st.tnear[0] = B(T(0));
    st.sp = 1;
    M pending = valid;
    while (st.sp > 0) {
      const int i = --st.sp;
      const M mask = st.mask[i] & pending;
      if (!xsimd::any(mask)) continue;
      if (st.count[i] >= 0) {
        pending = leaf(st.child[i], st.count[i], mask, pending);
        if (!xsimd::any(pending)) return pending;
      } else {
        push_children<kPadded>(h.nodes[std::size_t(st.child[i])], Bvh<T>::kSlotOrder, r, mask, tmax,
                               st);
      }
    }
    return pending;
  }
};

}  // namespace lancer::packet
