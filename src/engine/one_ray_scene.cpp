// What the one-ray kernels read beside the prepared scene (packet/one_ray_api.hpp): the 4-wide
// hierarchy collapsed into 8-wide float nodes, the spheres in leaf blocks (float's eight,
// double's four).
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include "lancer/packet/one_ray_api.hpp"

namespace lancer::packet {

namespace {

struct Slot {
  float lo[3], hi[3];
  std::int32_t child, count;
  float area() const {
    const float x = hi[0] - lo[0], y = hi[1] - lo[1], z = hi[2] - lo[2];
    return x * y + y * z + z * x;
  }
};

// A double box as a float one the float slab test cannot miss where the double one is met:
// rounded outward and grown by twice the float hierarchy's own padding for the same magnitudes
// (build_bvh: 2^8 ulps of float per unit of the origin limit and of the coordinates), which
// covers the float rounding of the ray and of the slab products.
void float_box(double limit, const double lo[3], const double hi[3], float flo[3], float fhi[3]) {
  double m = 0;
  for (int a = 0; a < 3; ++a) m = std::max({m, std::fabs(lo[a]), std::fabs(hi[a])});
  const double pad = 2.0 * 256.0 * double(std::numeric_limits<float>::epsilon()) * (limit + m);
  constexpr float kInf = std::numeric_limits<float>::infinity();
  for (int a = 0; a < 3; ++a) {
    flo[a] = std::nextafter(float(lo[a] - pad), -kInf);
    fhi[a] = std::nextafter(float(hi[a] + pad), kInf);
  }
}

// The children of 4-wide node i as slots: float's boxes as they are, double's as float_box.
template <class T>
void children(const Bvh<T>& h, std::int32_t i, std::vector<Slot>& out) {
  const typename Bvh<T>::Node& n = h.nodes[std::size_t(i)];
  for (int k = 0; k < n.arity; ++k) {
    Slot s{{}, {}, n.child[k], std::int32_t(n.count[k])};
    const T lo[3] = {n.lo_x[k], n.lo_y[k], n.lo_z[k]}, hi[3] = {n.hi_x[k], n.hi_y[k], n.hi_z[k]};
    if constexpr (std::is_same_v<T, float>) {
      std::copy(lo, lo + 3, s.lo), std::copy(hi, hi + 3, s.hi);
    } else {
      float_box(double(h.origin_limit), lo, hi, s.lo, s.hi);
    }
    out.push_back(s);
  }
}

// The leaf of `count` spheres from leaf-order index `first` as blocks appended to one.leaves
// (ids in one.ids); returns its first block.
template <class T>
std::int32_t leaf_blocks(const Bvh<T>& h, std::int32_t first, std::int32_t count,
                         OneRayScene<T>& one) {
  constexpr int kLanes = OneRayLeaf<T>::kLanes;
  const std::int32_t at = std::int32_t(one.leaves.size());
  const T nan = std::numeric_limits<T>::quiet_NaN();
  for (std::int32_t b = 0; b < count; b += kLanes) {
    OneRayLeaf<T> l;
    for (int q = 0; q < kLanes; ++q) {
      const std::int32_t j = first + b + q;
      const bool used = b + q < count;
      const std::size_t u = std::size_t(j);
      l.cx[q] = used ? h.cx[u] : nan, l.cy[q] = used ? h.cy[u] : nan;
      l.cz[q] = used ? h.cz[u] : nan, l.r2[q] = used ? h.r2[u] : nan;
      one.ids.push_back(used ? h.id[u] : -1);
    }
    one.leaves.push_back(l);
  }
  return at;
}

// The 8-wide node standing for 4-wide node i (and its subtree), appended to one.nodes8: its
// children, then, while they fit in eight, the inner child of largest surface replaced by its
// own children (the usual collapse of a binary or 4-wide tree into a wider one). A leaf slot
// names its first block (leaf_blocks). Returns its index.
template <class T>
std::int32_t collapse(const Bvh<T>& h, std::int32_t i, OneRayScene<T>& one) {
  std::vector<OneRayNode8>& out = one.nodes8;
  std::vector<Slot> slots;
  children(h, i, slots);
  for (;;) {
    int best = -1;
    for (int k = 0; k < int(slots.size()); ++k) {
      if (slots[std::size_t(k)].count >= 0) continue;
      const int arity = h.nodes[std::size_t(slots[std::size_t(k)].child)].arity;
      if (int(slots.size()) - 1 + arity > 8) continue;
      if (best < 0 || slots[std::size_t(k)].area() > slots[std::size_t(best)].area()) best = k;
    }
    if (best < 0) break;
    const std::int32_t opened = slots[std::size_t(best)].child;
    slots.erase(slots.begin() + best);
    children(h, opened, slots);
  }
  const std::int32_t at = std::int32_t(out.size());
  out.emplace_back();
  constexpr float kInf = std::numeric_limits<float>::infinity();
  for (int k = 0; k < 8; ++k) {
    OneRayNode8& n = out[std::size_t(at)];
    if (k >= int(slots.size())) {
      n.lo_x[k] = n.lo_y[k] = n.lo_z[k] = kInf;
      n.hi_x[k] = n.hi_y[k] = n.hi_z[k] = -kInf;
      n.child[k] = 0, n.count[k] = 0;
      continue;
    }
    const Slot& s = slots[std::size_t(k)];
    n.lo_x[k] = s.lo[0], n.lo_y[k] = s.lo[1], n.lo_z[k] = s.lo[2];
    n.hi_x[k] = s.hi[0], n.hi_y[k] = s.hi[1], n.hi_z[k] = s.hi[2];
    n.count[k] = s.count < 0 ? -1 : s.count;
    n.child[k] = s.count < 0 ? s.child : leaf_blocks(h, s.child, s.count, one);
  }
  // Inner children after the node itself is written (the recursion grows `out`).
  for (int k = 0; k < int(slots.size()); ++k)
    if (slots[std::size_t(k)].count < 0) {
      const std::int32_t c = collapse(h, slots[std::size_t(k)].child, one);
      out[std::size_t(at)].child[k] = c;
    }
  return at;
}

}  // namespace

OneRayScene<float> one_ray_scene(const Bvh<float>& h) {
  OneRayScene<float> s;
  if (h.active()) collapse(h, 0, s);
  return s;
}

OneRayScene<double> one_ray_scene(const Bvh<double>& h) {
  OneRayScene<double> s;
  if (h.active()) collapse(h, 0, s);
  return s;
}

}  // namespace lancer::packet
