// One-ray traversal of the sphere hierarchy (lancer/bvh.hpp), for the reference: the same visiting
// rules as the packets' (packet/traversal.hpp), the primitive tests left to the caller's leaf
// functor. Closest hit: nearer children first by the ray's direction; the caller keeps the
// lexicographic minimum of (t, object id), so the order cannot change the result. Any hit: the
// children's fixed slot order, depth first, as every packet visits them.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "lancer/bvh.hpp"
#include "lancer/vec3.hpp"

namespace lancer {

template <class T>
class RayTraversal {
 public:
  using Node = typename Bvh<T>::Node;

  RayTraversal(const Bvh<T>& h, const Vec3<T>& o, const Vec3<T>& d) : h_(h) {
    // As the packets: a zero direction component becomes 2^-64 (finite reciprocal, no NaN).
    auto rcp = [](T x) { return T(1) / (std::fabs(x) < T(0x1p-64) ? T(0x1p-64) : x); };
    inv_ = {rcp(d.x), rcp(d.y), rcp(d.z)};
    oi_ = {o.x * inv_.x, o.y * inv_.y, o.z * inv_.z};
    // Beyond the origin limit, boxes grow with |origin| (as the packets' padded traversal).
    const T m = std::max({std::fabs(o.x), std::fabs(o.y), std::fabs(o.z)});
    const T far = m > h.origin_limit ? m * T(Bvh<T>::kOriginPad) : T(0);
    pad_ = {far * std::fabs(inv_.x), far * std::fabs(inv_.y), far * std::fabs(inv_.z)};
    code_ = unsigned(d.x >= T(0)) | unsigned(d.y >= T(0)) << 1 | unsigned(d.z >= T(0)) << 2;
  }

  // Whether the ray starts beyond Bvh::kFarLimit (the caller then loops over all spheres).
  static bool beyond(const Bvh<T>& h, const Vec3<T>& o) {
    return h.active() &&
           std::max({std::fabs(o.x), std::fabs(o.y), std::fabs(o.z)}) > T(Bvh<T>::kFarLimit);
  }

  // leaf(first, count) tests leaf-order spheres [first, first + count), lowering best_t.
  template <class Leaf>
  void closest(const T& best_t, Leaf&& leaf) const {
    walk(
        best_t, [&](const Node& n) { return unsigned(n.order[code_]); },
        [&](std::int32_t first, std::int32_t count) {
          leaf(first, count);
          return false;
        },
        [&](T tnear) { return tnear > best_t; });
  }

  // leaf(first, count) -> true to stop. Returns whether a leaf stopped it.
  template <class Leaf>
  bool any(const T& tmax, Leaf&& leaf) const {
    return walk(
        tmax, [](const Node&) { return Bvh<T>::kSlotOrder; }, leaf, [](T) { return false; });
  }

 private:
  struct Entry {
    std::int32_t child, count;
    T tnear;
  };

  // The depth-first walk both queries share: at a wide node, the children its ray meets within
  // tmax (read afresh: leaves lower it) pushed in order(n)'s slot order, last
  // first, so the first is visited next. leaf(first, count) -> true to stop; a popped subtree
  // is skipped where cull(tnear).
  template <class Order, class Leaf, class Cull>
  bool walk(const T& tmax, Order order, Leaf&& leaf, Cull cull) const {
    Entry stack[Bvh<T>::kStack];
    stack[0] = {0, -1, T(0)};
    int sp = 1;
    while (sp > 0) {
      const Entry e = stack[--sp];
      if (cull(e.tnear)) continue;
      if (e.count >= 0) {
        if (leaf(e.child, e.count)) return true;
        continue;
      }
      const Node& n = h_.nodes[std::size_t(e.child)];
      const unsigned ord = order(n);
      for (int p = Bvh<T>::kWidth - 1; p >= 0; --p) {
        const int k = int(ord >> (Bvh<T>::kOrderBits * p)) & (Bvh<T>::kWidth - 1);
        T tn;
        if (k < n.arity && hit(n, k, tmax, tn)) stack[sp++] = {n.child[k], n.count[k], tn};
      }
    }
    return false;
  }

  bool hit(const Node& n, int k, const T& tmax, T& tnear) const {
    const T x0 = n.lo_x[k] * inv_.x - oi_.x, x1 = n.hi_x[k] * inv_.x - oi_.x;
    const T y0 = n.lo_y[k] * inv_.y - oi_.y, y1 = n.hi_y[k] * inv_.y - oi_.y;
    const T z0 = n.lo_z[k] * inv_.z - oi_.z, z1 = n.hi_z[k] * inv_.z - oi_.z;
    tnear = std::max(
        {std::min(x0, x1) - pad_.x, std::min(y0, y1) - pad_.y, std::min(z0, z1) - pad_.z, T(0)});
    const T tfar = std::min(
        {std::max(x0, x1) + pad_.x, std::max(y0, y1) + pad_.y, std::max(z0, z1) + pad_.z, tmax});
    return tnear <= tfar;
  }

  const Bvh<T>& h_;
  Vec3<T> inv_, oi_, pad_;
  unsigned code_;  // the ray's direction code (Bvh::Node::order)
};

}  // namespace lancer
