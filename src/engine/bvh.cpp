// Binned SAH build of the sphere hierarchy (include/lancer/bvh.hpp): top-down, up to 32 bins per
// axis over the centroids, in-place partition of the spheres' boxes; large subtrees build as
// parallel tasks (TBB). The result is a function of the input only, the same for any thread count.
#include "lancer/bvh.hpp"

#include <tbb/task_group.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>

#include "lancer/error.hpp"

namespace lancer {

const char* to_string(Accel a) {
  switch (a) {
    case Accel::automatic:
      return "auto";
    case Accel::none:
      return "none";
    case Accel::bvh:
      return "bvh";
    case Accel::one:
      return "one";
  }
  return "?";
}

template <class T>
std::size_t Bvh<T>::bytes() const {
  return nodes.size() * sizeof(Node) + first_sphere.size() * sizeof(std::int32_t) +
         (cx.size() + cy.size() + cz.size() + r2.size()) * sizeof(T) +
         (id.size() + leaf_of.size()) * sizeof(std::int32_t);
}

// The 32-byte vectors of double change the calling convention without AVX (-Wpsabi): these are
// internal to this file, never passed across a library boundary.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace {

// Four lanes (x, y, z, unused) as one vector (GCC's vector extension): a box grows by two
// min/max instructions.
// A node of the binary tree the build makes (then collapsed into Bvh<T>::Node): its two
// children's boxes, references and counts (< 0: inner) as the wide node's, and its split axis.
template <class T>
struct alignas(64) BinaryNode {  // one cache line: parallel tasks never write the same line
  T lo_x[2], hi_x[2], lo_y[2], hi_y[2], lo_z[2], hi_z[2];
  std::int32_t child[2];
  std::int16_t count[2];
  std::int32_t axis;
};

template <class T>
struct Vector4;
template <>
struct Vector4<float> {
  typedef float type __attribute__((vector_size(16)));
};
template <>
struct Vector4<double> {
  typedef double type __attribute__((vector_size(32)));
};
template <class T>
using V4 = typename Vector4<T>::type;

template <class V>
V vmin(const V& a, const V& b) {
  return a < b ? a : b;
}
template <class V>
V vmax(const V& a, const V& b) {
  return a > b ? a : b;
}

template <class T>
struct Box {
  V4<T> lo, hi;
  static Box empty() {
    constexpr T inf = std::numeric_limits<T>::infinity();
    return {V4<T>{inf, inf, inf, inf}, V4<T>{-inf, -inf, -inf, -inf}};
  }
  void grow(const Box& b) { lo = vmin(lo, b.lo), hi = vmax(hi, b.hi); }
  void grow(const V4<T>& p) { lo = vmin(lo, p), hi = vmax(hi, p); }
  // Half the surface area (the SAH needs ratios only), in T: the split choice only compares.
  double half_area() const {
    const V4<T> d = hi - lo;
    return double(d[0] * (d[1] + d[2]) + d[1] * d[2]);
  }
};

// A sphere's padded box; lo + hi (twice its centre, up to rounding) is the point binned.
template <class T>
struct Prim {
  Box<T> box;
  V4<T> centroid() const { return box.lo + box.hi; }
};

constexpr int kBins = 32;  // per axis, at most (min(kBins, n)); docs/accel.md
// Always a leaf at or below (Bvh::max_leaf); else split. kLargeLeaf from kLargeLeafMinSpheres
// (bvh.hpp).
constexpr int kSmallLeaf = 4, kLargeLeaf = 8;
constexpr int kParallelMin = 4096;  // subtrees at least this large build as parallel tasks
// A bottom node's spheres (Bvh::Node::count): an 8-bit count, the cones' 32-bit masks.
static_assert(Bvh<float>::kWidth * kLargeLeaf <= 32, "a wide node's counts are 8 bits");

// Top-down binned SAH over prims_/idx_ (partitioned in place, in lockstep). Which spheres a
// subtree holds depends on the input only; where its nodes sit in nodes_ depends on the tasks'
// timing, and nothing reads that but the collapse, which follows the children from the root.
// Each task takes node slots kChunk at a time from one count, so the used slots are dense: the
// bound of n - 1 inner nodes (about three times what SAH trees use) is reserved, never touched.
template <class T>
class Builder {
 public:
  using Node = BinaryNode<T>;
  static constexpr int kChunk = 64;
  Builder(BigVector<Prim<T>>& prims, std::vector<std::int32_t>& idx, int max_leaf)
      : prims_(prims), idx_(idx), max_leaf_(max_leaf), nodes_(capacity(prims.size())) {}

  // A task's slots: [next, end) of its chunk; and the deepest child depth it made (the root's
  // children: 1), merged into its parent task's after it, so no shared state per node.
  struct Slots {
    int next = 0, end = 0, deepest = 0;
  };
  int take(Slots& s) {
    if (s.next == s.end) {
      s.next = count_.fetch_add(kChunk), s.end = s.next + kChunk;
      LANCER_CHECK(std::size_t(s.end) <= nodes_.size());
    }
    return s.next++;
  }
  // Inner nodes (n - 1 at most) and every task's unused rest of a chunk: a task per subtree of
  // at least kParallelMin spheres, so fewer than n / kParallelMin + 1 of them.
  static std::size_t capacity(std::size_t n) {
    return n + std::size_t(kChunk) * (n / std::size_t(kParallelMin) + 2);
  }

  struct Split {
    int axis = -1, bin = -1, last = 0;  // last: the highest bin
    double cost = std::numeric_limits<double>::infinity();
    T cmin = 0, scale = 0;
    Box<T> left, right;  // the two sides' boxes (from the bins: exact unions)
  };

  // The inner node at `slot` over [begin, end) (at least 2 spheres), split by `s` (axis < 0:
  // halved by index), and its two subtrees.
  void inner(Slots& slots, int slot, int begin, int end, Split s, int depth) {
    const int n = end - begin;
    int mid;
    Box<T> lc = Box<T>::empty(), rc = Box<T>::empty();  // the sides' centroid bounds
    if (s.axis < 0) {
      mid = begin + n / 2;
      s.left = bounds(begin, mid, lc), s.right = bounds(mid, end, rc);
    } else {
      mid = partition(begin, end, s, lc, rc);
    }
    nodes_[std::size_t(slot)].axis = std::max(0, s.axis);
    if (mid - begin >= kParallelMin && end - mid >= kParallelMin) {
      tbb::task_group g;
      Slots own;
      g.run([&] { child(own, slot, 0, begin, mid, s.left, lc, depth + 1); });
      child(slots, slot, 1, mid, end, s.right, rc, depth + 1);
      g.wait();
      slots.deepest = std::max(slots.deepest, own.deepest);
    } else {
      child(slots, slot, 0, begin, mid, s.left, lc, depth + 1);
      child(slots, slot, 1, mid, end, s.right, rc, depth + 1);
    }
  }

  // Child k of the node at `parent`: a leaf or an inner node.
  void child(Slots& slots, int parent, int k, int begin, int end, const Box<T>& box,
             const Box<T>& cbox, int depth) {
    Node& p = nodes_[std::size_t(parent)];
    set_box(p, k, box);
    const int n = end - begin;
    slots.deepest = std::max(slots.deepest, depth);
    if (n <= max_leaf_) return leaf(p, k, begin, n);
    const Split s = depth < Bvh<T>::kMaxTreeDepth - 40 ? best_split(begin, end, cbox) : Split{};
    const int free = take(slots);
    p.child[k] = free, p.count[k] = -1;
    inner(slots, free, begin, end, s, depth);
  }

  static void set_box(Node& p, int k, const Box<T>& b) {
    p.lo_x[k] = b.lo[0], p.lo_y[k] = b.lo[1], p.lo_z[k] = b.lo[2];
    p.hi_x[k] = b.hi[0], p.hi_y[k] = b.hi[1], p.hi_z[k] = b.hi[2];
  }
  static void leaf(Node& p, int k, int begin, int n) { p.child[k] = begin, p.count[k] = n; }

  Box<T> bounds(int begin, int end, Box<T>& cbox) const {
    Box<T> b = Box<T>::empty();
    for (int i = begin; i < end; ++i) {
      b.grow(prims_[std::size_t(i)].box);
      cbox.grow(prims_[std::size_t(i)].centroid());
    }
    return b;
  }

  static int bin_of(const Split& s, T c) {
    return std::min(s.last, std::max(0, static_cast<int>((c - s.cmin) * s.scale)));
  }

  // The cheapest of the bins - 1 planes per axis by the surface area heuristic, in the units
  // of the leaf cost n * area (without the node's own traversal cost). cbox: the centroids'.
  // Small sets get as many bins as spheres (most nodes are small: fewer bins to sweep).
  Split best_split(int begin, int end, const Box<T>& cbox) const {
    const int bins = std::min(kBins, end - begin);
    Box<T> bin_box[3][kBins];
    int bin_count[3][kBins] = {};
    Split probe[3];
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < bins; ++b) bin_box[a][b] = Box<T>::empty();
      probe[a].cmin = cbox.lo[a];
      probe[a].last = bins - 1;
      const T extent = cbox.hi[a] - cbox.lo[a];
      probe[a].scale = extent > 0 ? T(bins) / extent * T(0.99999) : T(0);
    }
    const V4<T> cmin = cbox.lo;
    const V4<T> scale{probe[0].scale, probe[1].scale, probe[2].scale, T(0)};
    for (int i = begin; i < end; ++i) {
      const Prim<T>& p = prims_[std::size_t(i)];
      const V4<T> f = (p.centroid() - cmin) * scale;
      for (int a = 0; a < 3; ++a) {
        const int b = std::min(bins - 1, std::max(0, static_cast<int>(f[a])));
        ++bin_count[a][b];
        bin_box[a][b].grow(p.box);
      }
    }
    Split best;
    for (int a = 0; a < 3; ++a) {
      if (!(probe[a].scale > 0)) continue;
      Box<T> right[kBins];
      double right_cost[kBins];
      Box<T> acc = Box<T>::empty();
      int count = 0;
      for (int b = bins - 1; b > 0; --b) {
        acc.grow(bin_box[a][b]);
        count += bin_count[a][b];
        right[b] = acc;
        right_cost[b] = count ? acc.half_area() * count : 0.0;
      }
      acc = Box<T>::empty();
      count = 0;
      for (int b = 0; b < bins - 1; ++b) {
        acc.grow(bin_box[a][b]);
        count += bin_count[a][b];
        if (count == 0 || count == end - begin) continue;
        const double cost = acc.half_area() * count + right_cost[b + 1];
        if (cost < best.cost) {
          best.cmin = probe[a].cmin, best.scale = probe[a].scale, best.last = bins - 1;
          best.axis = a, best.bin = b, best.cost = cost;
          best.left = acc, best.right = right[b + 1];
        }
      }
    }
    return best;
  }

  // Sphere i goes left iff its centroid's bin is at most s.bin (as best_split binned it).
  // Branch-free (Lomuto: every element swapped with the first right one; which side an element
  // goes to is a coin toss the branch predictor cannot learn). lc, rc: the two sides' centroid
  // bounds, for their own splits.
  int partition(int begin, int end, const Split& s, Box<T>& lc, Box<T>& rc) {
    switch (s.axis) {
      case 0:
        return partition_on<0>(begin, end, s, lc, rc);
      case 1:
        return partition_on<1>(begin, end, s, lc, rc);
      default:
        return partition_on<2>(begin, end, s, lc, rc);
    }
  }
  template <int kAxis>
  int partition_on(int begin, int end, const Split& s, Box<T>& lc, Box<T>& rc) {
    Prim<T>* p = prims_.data();
    std::int32_t* idx = idx_.data();
    int mid = begin;
    for (int i = begin; i < end; ++i) {
      const Prim<T> q = p[i];
      const std::int32_t qi = idx[i];
      const bool left = bin_of(s, q.centroid()[kAxis]) <= s.bin;
      p[i] = p[mid], idx[i] = idx[mid];
      p[mid] = q, idx[mid] = qi;
      mid += left;
    }
    Box<T> l = Box<T>::empty(), r = Box<T>::empty();
    for (int i = begin; i < mid; ++i) l.grow(p[i].centroid());
    for (int i = mid; i < end; ++i) r.grow(p[i].centroid());
    lc = l, rc = r;
    return mid;
  }

  Node& node(int slot) { return nodes_[std::size_t(slot)]; }
  const BigArray<Node>& nodes() const { return nodes_; }
  int used() const { return count_.load(); }  // slots taken (some chunks' rests unused)

 private:
  BigVector<Prim<T>>& prims_;
  std::vector<std::int32_t>& idx_;
  int max_leaf_;
  BigArray<Node> nodes_;
  std::atomic<int> count_{0};
};

// The binary tree collapsed into kWidth-wide nodes, in depth-first pre-order. A wide node over
// binary node b opens b's inner children (so each inner child of a wide node lies two binary levels
// down: the wide depth is at most half the binary one), then, while slots remain, the inner
// child of largest area. Opening in place keeps the depth-first order of the leaves.
template <class T>
class Collapse {
 public:
  using Node = typename Bvh<T>::Node;
  Collapse(const BigArray<BinaryNode<T>>& bin, BigVector<Node>& out,
           std::vector<std::int32_t>& first)
      : bin_(bin), out_(out), first_(first) {}

  // The wide node over binary node b at wide depth `depth`: returns its index.
  std::int32_t node(int b, int depth) {
    constexpr int kW = Bvh<T>::kWidth;
    deepest = std::max(deepest, depth);
    Ref e[kW] = {{b, 0}, {b, 1}};
    int n = 2;
    auto open = [&](int i) {
      const Ref r = e[i];
      for (int j = n; j > i + 1; --j) e[j] = e[j - 1];
      e[i] = {at(r).child[r.k], 0}, e[i + 1] = {at(r).child[r.k], 1};
      ++n;
    };
    for (int i = 1; i >= 0; --i)
      if (inner(e[i])) open(i);
    while (n < kW) {
      int best = -1;
      double area = -1;
      for (int i = 0; i < n; ++i)
        if (inner(e[i]) && half_area(e[i]) > area) best = i, area = half_area(e[i]);
      if (best < 0) break;
      open(best);
    }
    // A one-sphere tree's empty slot (a leaf of 0 spheres) is dropped.
    int arity = 0;
    for (int i = 0; i < n; ++i)
      if (inner(e[i]) || at(e[i]).count[e[i].k] > 0) e[arity++] = e[i];
    const auto self = static_cast<std::int32_t>(out_.size());
    out_.emplace_back();  // value-initialized: padding and unused slots are zero
    first_.push_back(-1);
    std::int32_t child[kW] = {};
    for (int i = 0; i < arity; ++i)
      child[i] = inner(e[i]) ? node(at(e[i]).child[e[i].k], depth + 1) : at(e[i]).child[e[i].k];
    Node& w = out_[std::size_t(self)];
    w.arity = arity;
    for (int i = 0; i < arity; ++i) {
      const BinaryNode<T>& p = at(e[i]);
      const int k = e[i].k;
      w.lo_x[i] = p.lo_x[k], w.lo_y[i] = p.lo_y[k], w.lo_z[i] = p.lo_z[k];
      w.hi_x[i] = p.hi_x[k], w.hi_y[i] = p.hi_y[k], w.hi_z[i] = p.hi_z[k];
      w.child[i] = child[i];
      w.count[i] = static_cast<std::int8_t>(inner(e[i]) ? -1 - bottom(child[i]) : p.count[k]);
    }
    if (bottom(self)) first_[std::size_t(self)] = w.child[0];  // what its parent will mark
    // Per direction code u, the slots in the binary traversal's near-first order.
    for (unsigned u = 0; u < 8; ++u) {
      int p = 0;
      std::uint32_t code = 0;
      emit(b, u, e, arity, code, p);
      for (int i = arity; i < kW; ++i, ++p) code |= std::uint32_t(i) << (Bvh<T>::kOrderBits * p);
      w.order[u] = static_cast<typename Bvh<T>::Order>(code);
    }
    return self;
  }

  int deepest = 0;

 private:
  struct Ref {
    int b, k;  // child k of binary node b
  };
  const BinaryNode<T>& at(const Ref& r) const { return bin_[std::size_t(r.b)]; }
  bool inner(const Ref& r) const { return at(r).count[r.k] < 0; }
  double half_area(const Ref& r) const {
    const BinaryNode<T>& p = at(r);
    const double dx = double(p.hi_x[r.k]) - p.lo_x[r.k], dy = double(p.hi_y[r.k]) - p.lo_y[r.k],
                 dz = double(p.hi_z[r.k]) - p.lo_z[r.k];
    return dx * (dy + dz) + dy * dz;
  }
  // The slots under binary node x, the near child first (child 0 where the rays go up x's axis).
  void emit(int x, unsigned u, const Ref* e, int arity, std::uint32_t& code, int& p) const {
    const int near = (u >> bin_[std::size_t(x)].axis) & 1 ? 0 : 1;
    for (const int k : {near, 1 - near}) {
      int slot = -1;
      for (int i = 0; i < arity; ++i)
        if (e[i].b == x && e[i].k == k) slot = i;
      if (slot >= 0)
        code |= std::uint32_t(slot) << (Bvh<T>::kOrderBits * p++);
      else if (bin_[std::size_t(x)].count[k] < 0)
        emit(bin_[std::size_t(x)].child[k], u, e, arity, code, p);
    }
  }

  // 1 + its spheres where wide node c's children are leaves only (consecutive in leaf order),
  // else 0: the count its parent gives it is -1 minus this.
  int bottom(std::int32_t c) const {
    const Node& n = out_[std::size_t(c)];
    int spheres = 0;
    for (int q = 0; q < n.arity; ++q) {
      if (n.count[q] < 0 || n.child[q] != n.child[0] + spheres) return 0;
      spheres += n.count[q];
    }
    return 1 + spheres;
  }

  const BigArray<BinaryNode<T>>& bin_;
  BigVector<Node>& out_;
  std::vector<std::int32_t>& first_;
};

// Padding per unit of magnitude: 2^8 ulps of T, far above the rounding of the sphere test
// (a few ulps of |origin - centre|) and of the slab test, so no ray the plain loop finds a sphere
// for misses its box.
template <class T>
constexpr double kPad = std::numeric_limits<T>::epsilon() * 256.0;

// The scale a packet's spread is judged against (Bvh::coherent_spread): the root box's diagonal
// and the median leaf box's.
template <class T>
void set_spread_scale(Bvh<T>& bvh, const Box<T>& all) {
  auto diagonal = [](double x, double y, double z) { return std::sqrt(x * x + y * y + z * z); };
  bvh.diagonal =
      T(diagonal(double(all.hi[0]) - double(all.lo[0]), double(all.hi[1]) - double(all.lo[1]),
                 double(all.hi[2]) - double(all.lo[2])));
  BigVector<double> leaves;
  for (const auto& nd : bvh.nodes)
    for (int k = 0; k < nd.arity; ++k)
      if (nd.count[k] > 0)
        leaves.push_back(diagonal(double(nd.hi_x[k]) - double(nd.lo_x[k]),
                                  double(nd.hi_y[k]) - double(nd.lo_y[k]),
                                  double(nd.hi_z[k]) - double(nd.lo_z[k])));
  if (leaves.empty()) return;
  const auto mid = leaves.begin() + std::ptrdiff_t(leaves.size() / 2);
  std::nth_element(leaves.begin(), mid, leaves.end());
  bvh.leaf_diagonal = T(*mid);
  bvh.coherent_spread = T(kCoherentLeaves * *mid);
}

}  // namespace

template <class T>
Bvh<T> build_bvh(const std::vector<T>& cx, const std::vector<T>& cy, const std::vector<T>& cz,
                 const std::vector<T>& r, int n, std::vector<std::int32_t>& order,
                 double eye_reach) {
  const auto start = std::chrono::steady_clock::now();
  Bvh<T> bvh;
  order.resize(std::size_t(n));
  if (n == 0) return bvh;
  // Rays start at the camera (eye_reach from the origin), on spheres, or on planes (anywhere).
  double reach = eye_reach;
  for (int i = 0; i < n; ++i)
    reach = std::max({reach, std::fabs(double(cx[std::size_t(i)])) + double(r[std::size_t(i)]),
                      std::fabs(double(cy[std::size_t(i)])) + double(r[std::size_t(i)]),
                      std::fabs(double(cz[std::size_t(i)])) + double(r[std::size_t(i)])});
  const double limit = 4.0 * reach;
  bvh.origin_limit = T(limit);
  BigVector<Prim<T>> prims;
  prims.reserve(std::size_t(n));  // written once below, not zeroed first
  Box<T> all = Box<T>::empty(), call = Box<T>::empty();
  for (int i = 0; i < n; ++i) {
    const std::size_t k = std::size_t(i);
    const double c[3] = {double(cx[k]), double(cy[k]), double(cz[k])};
    const double rad = double(r[k]);
    const double big = std::max({std::fabs(c[0]), std::fabs(c[1]), std::fabs(c[2])});
    const double pad = kPad<T> * (limit + big + rad);
    prims.push_back({{V4<T>{T(c[0] - rad - pad), T(c[1] - rad - pad), T(c[2] - rad - pad), T(0)},
                      V4<T>{T(c[0] + rad + pad), T(c[1] + rad + pad), T(c[2] + rad + pad), T(0)}}});
    const Prim<T>& q = prims.back();
    all.grow(q.box);
    call.grow(q.centroid());
    order[k] = i;
  }
  bvh.max_leaf = n >= kLargeLeafMinSpheres ? kLargeLeaf : kSmallLeaf;
  Builder<T> builder(prims, order, bvh.max_leaf);
  typename Builder<T>::Slots slots;
  const int root = builder.take(slots);  // slot 0
  // One sphere: the root's child 0 holds it, child 1 is empty.
  if (n == 1) {
    for (int k = 0; k < 2; ++k) Builder<T>::set_box(builder.node(root), k, all);
    Builder<T>::leaf(builder.node(root), 0, 0, 1);
    Builder<T>::leaf(builder.node(root), 1, 1, 0);
    builder.node(root).axis = 0;
  } else {  // the root holds the two top subtrees' boxes, whatever their size
    builder.inner(slots, root, 0, n, builder.best_split(0, n, call), 0);
  }
  LANCER_CHECK(std::max(1, slots.deepest) < Bvh<T>::kMaxTreeDepth);
  bvh.nodes.reserve(std::size_t(builder.used()) / 2 + 1);
  bvh.first_sphere.reserve(bvh.nodes.capacity());
  Collapse<T> collapse(builder.nodes(), bvh.nodes, bvh.first_sphere);
  collapse.node(root, 1);
  bvh.depth = collapse.deepest;
  set_spread_scale(bvh, all);
  LANCER_CHECK((Bvh<T>::kWidth - 1) * bvh.depth + 1 <= Bvh<T>::kStack);
  bvh.build_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return bvh;
}

template struct Bvh<float>;
template struct Bvh<double>;
template Bvh<float> build_bvh<float>(const std::vector<float>&, const std::vector<float>&,
                                     const std::vector<float>&, const std::vector<float>&, int,
                                     std::vector<std::int32_t>&, double);
template Bvh<double> build_bvh<double>(const std::vector<double>&, const std::vector<double>&,
                                       const std::vector<double>&, const std::vector<double>&, int,
                                       std::vector<std::int32_t>&, double);

}  // namespace lancer
