// Packet traversal of the sphere hierarchy (lancer/bvh.hpp), apart from the primitive tests: the
// caller's leaf functor tests the spheres of a leaf for the lanes whose ray meets its box.
// Include only from packet/kernel.hpp (code built for the batch's ISA).
//
// Closest hit: the packet visits the nearer child first by its direction's sign on the node's
// split axis and re-culls popped subtrees against the lanes' best t. The result does not depend
// on the order: the leaf functor keeps the lexicographic minimum of (t, object id).
// Any hit: children in their FIXED order (0 then 1), depth first, for every packet and every ray,
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

  struct Entry {
    std::int32_t child, count;
    M mask;
    B tnear;
  };

  // leaf(first, count, mask): tests leaf-order spheres [first, first + count) for `mask`,
  // lowering best_t (read here to cull).
  template <bool kPadded, class Leaf>
  static void closest(const Bvh<T>& h, const M& valid, const V& o, const V& d, const B& best_t,
                      Leaf&& leaf) noexcept {
    const Ray r = slab_ray(o, d);
    // The packet's mean direction picks the nearer child per split axis.
    bool up[3];
    alignas(64) T lanes[B::size];
    const B* axes[3] = {&d.x, &d.y, &d.z};
    for (int a = 0; a < 3; ++a) {
      xsimd::select(valid, *axes[a], B(T(0))).store_aligned(lanes);
      T sum(0);
      for (std::size_t k = 0; k < B::size; ++k) sum += lanes[k];
      up[a] = sum >= T(0);
    }
    Entry stack[Bvh<T>::kMaxDepth + 2];
    int sp = 0;
    std::int32_t child = 0, count = -1;
    M mask = valid;
    for (;;) {
      if (count < 0) {
        const Node& n = h.nodes[std::size_t(child)];
        const int near = up[n.axis] ? 0 : 1, far = 1 - near;
        B tn_near, tn_far;
        const M m_near = child_hit<kPadded>(n, near, r, mask, best_t, tn_near);
        const M m_far = child_hit<kPadded>(n, far, r, mask, best_t, tn_far);
        const bool a_near = xsimd::any(m_near), a_far = xsimd::any(m_far);
        if (a_near) {
          if (a_far) stack[sp++] = {n.child[far], n.count[far], m_far, tn_far};
          child = n.child[near], count = n.count[near], mask = m_near;
          continue;
        }
        if (a_far) {
          child = n.child[far], count = n.count[far], mask = m_far;
          continue;
        }
      } else {
        leaf(child, count, mask);
      }
      for (;;) {  // the next subtree some lane may still find a nearer hit in
        if (sp == 0) return;
        const Entry& e = stack[--sp];
        mask = e.mask & (e.tnear <= best_t);
        if (xsimd::any(mask)) {
          child = e.child, count = e.count;
          break;
        }
      }
    }
  }

  // leaf(first, count, mask) -> the lanes still pending after that leaf (of `mask`'s and the
  // others). Returns the lanes of `valid` still pending at the end.
  template <bool kPadded, class Leaf>
  static M any(const Bvh<T>& h, const M& valid, const V& o, const V& d, const B& tmax,
               Leaf&& leaf) noexcept {
    const Ray r = slab_ray(o, d);
    Entry stack[Bvh<T>::kMaxDepth + 2];
    int sp = 0;
    std::int32_t child = 0, count = -1;
    M pending = valid, mask = valid;
    for (;;) {
      if (count < 0) {
        const Node& n = h.nodes[std::size_t(child)];
        B tn0, tn1;
        const M m0 = child_hit<kPadded>(n, 0, r, mask, tmax, tn0);
        const M m1 = child_hit<kPadded>(n, 1, r, mask, tmax, tn1);
        const bool a0 = xsimd::any(m0), a1 = xsimd::any(m1);
        if (a0) {
          if (a1) stack[sp++] = {n.child[1], n.count[1], m1, tn1};
          child = n.child[0], count = n.count[0], mask = m0;
          continue;
        }
        if (a1) {
          child = n.child[1], count = n.count[1], mask = m1;
          continue;
        }
      } else {
        pending = leaf(child, count, mask, pending);
        if (!xsimd::any(pending)) return pending;
      }
      for (;;) {
        if (sp == 0) return pending;
        const Entry& e = stack[--sp];
        mask = e.mask & pending;
        if (xsimd::any(mask)) {
          child = e.child, count = e.count;
          break;
        }
      }
    }
  }
};

}  // namespace lancer::packet
