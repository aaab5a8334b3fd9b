// One-ray traversal of the sphere hierarchy (lancer/bvh.hpp), for the reference: the same visiting
// rules as the packets' (packet/traverse.hpp), the primitive tests left to the caller's leaf
// functor. Closest hit: nearer child first by the ray's direction; the caller keeps the
// lexicographic minimum of (t, object id), so the order cannot change the result. Any hit: the
// children's fixed order, depth first, as every packet visits them.
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
    up_[0] = d.x >= T(0), up_[1] = d.y >= T(0), up_[2] = d.z >= T(0);
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
        best_t, [&](const Node& n) { return up_[n.axis] ? 0 : 1; },
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
        tmax, [](const Node&) { return 0; }, leaf, [](T) { return false; });
  }

 private:
  struct Entry {
    std::int32_t child, count;
    T tnear;
  };

  // The depth-first walk both queries share: at an inner node, child first(n) then the other,
  // each tested against tmax (read afresh: leaves lower it); the second pushed when both are
  // met. leaf(first, count) -> true to stop; a popped subtree is skipped where cull(tnear).
  template <class First, class Leaf, class Cull>
  bool walk(const T& tmax, First first, Leaf&& leaf, Cull cull) const {
    Entry stack[Bvh<T>::kMaxDepth + 2];
    int sp = 0;
    std::int32_t child = 0, count = -1;
    for (;;) {
      if (count < 0) {
        const Node& n = h_.nodes[std::size_t(child)];
        const int a = first(n), b = 1 - a;
        T tn_a, tn_b;
        const bool hit_a = hit(n, a, tmax, tn_a), hit_b = hit(n, b, tmax, tn_b);
        if (hit_a) {
          if (hit_b) stack[sp++] = {n.child[b], n.count[b], tn_b};
          child = n.child[a], count = n.count[a];
          continue;
        }
        if (hit_b) {
          child = n.child[b], count = n.count[b];
          continue;
        }
      } else if (leaf(child, count)) {
        return true;
      }
      for (;;) {  // the next subtree still worth a visit
        if (sp == 0) return false;
        const Entry& e = stack[--sp];
        if (!cull(e.tnear)) {
          child = e.child, count = e.count;
          break;
        }
      }
    }
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
  bool up_[3];
};

}  // namespace lancer
