// Binned SAH build of the sphere hierarchy (include/lancer/bvh.hpp): top-down, 16 bins per axis
// over the centroids, in-place partition of an index array. Single-threaded and deterministic.
#include "lancer/bvh.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "lancer/error.hpp"

namespace lancer {

Accel parse_accel(const std::string& text, const std::string& option) {
  if (text == "auto") return Accel::automatic;
  if (text == "none") return Accel::none;
  if (text == "bvh") return Accel::bvh;
  throw InputError(option + ": must be auto, none or bvh, not '" + text + "'");
}

const char* to_string(Accel a) {
  switch (a) {
    case Accel::automatic:
      return "auto";
    case Accel::none:
      return "none";
    case Accel::bvh:
      return "bvh";
  }
  return "?";
}

template <class T>
std::size_t Bvh<T>::bytes() const {
  return nodes.size() * sizeof(Node) +
         (cx.size() + cy.size() + cz.size() + r2.size() + eye_fx.size() + eye_fy.size() +
          eye_fz.size() + eye_c.size()) *
             sizeof(T) +
         id.size() * sizeof(std::int32_t);
}

namespace {

template <class T>
struct Box {
  T lo[3], hi[3];
  static Box empty() {
    constexpr T inf = std::numeric_limits<T>::infinity();
    return {{inf, inf, inf}, {-inf, -inf, -inf}};
  }
  void grow(const Box& b) {
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], b.lo[a]), hi[a] = std::max(hi[a], b.hi[a]);
  }
  // Half the surface area (the SAH needs ratios only).
  double half_area() const {
    const double x = double(hi[0]) - lo[0], y = double(hi[1]) - lo[1], z = double(hi[2]) - lo[2];
    return x * y + y * z + z * x;
  }
};

constexpr int kBins = 16;
constexpr int kMaxLeaf = 4;             // always a leaf at or below
constexpr int kMaxSahLeaf = 8;          // a leaf up to here where the SAH says a split does not pay
constexpr double kTraversalCost = 1.0;  // per node, in units of one sphere test

template <class T>
class Builder {
 public:
  Builder(Bvh<T>& bvh, const std::vector<Box<T>>& boxes, const std::vector<float>& centroid,
          std::vector<std::int32_t>& order)
      : bvh_(bvh), boxes_(boxes), centroid_(centroid), idx_(order) {}

  // Builds the subtree over idx_[begin, end) into child slot `slot` of node `parent`.
  void build(int parent, int slot, int begin, int end, const Box<T>& bounds, int depth) {
    typename Bvh<T>::Node& p = bvh_.nodes[std::size_t(parent)];
    set_box(p, slot, bounds);
    const int n = end - begin;
    if (n <= kMaxLeaf) return make_leaf(parent, slot, begin, n);
    Split s = depth < Bvh<T>::kMaxDepth - 40 ? best_split(begin, end) : Split{};
    // A small set that no split improves on stays a leaf.
    if (s.axis >= 0 && n <= kMaxSahLeaf && s.cost >= double(n) * bounds.half_area())
      return make_leaf(parent, slot, begin, n);
    // Centroids all equal (or the depth cap): halve by index, deterministic and balanced.
    if (s.axis < 0) s = median_split(begin, end);
    const int mid = s.axis >= 0 && s.bin >= 0 ? partition(begin, end, s) : s.mid;
    const int node = add_node(parent, slot, s.axis < 0 ? 0 : s.axis, depth + 1);
    build(node, 0, begin, mid, bounds_of(begin, mid), depth + 1);
    build(node, 1, mid, end, bounds_of(mid, end), depth + 1);
  }

  int add_node(int parent, int slot, int axis, int depth) {
    const int node = static_cast<int>(bvh_.nodes.size());
    bvh_.nodes.push_back({});
    bvh_.nodes.back().axis = axis;
    if (parent >= 0) {
      bvh_.nodes[std::size_t(parent)].child[slot] = node;
      bvh_.nodes[std::size_t(parent)].count[slot] = -1;
    }
    bvh_.depth = std::max(bvh_.depth, depth);
    return node;
  }

  Box<T> bounds_of(int begin, int end) const {
    Box<T> b = Box<T>::empty();
    for (int k = begin; k < end; ++k) b.grow(boxes_[std::size_t(idx_[std::size_t(k)])]);
    return b;
  }

  static void set_box(typename Bvh<T>::Node& p, int slot, const Box<T>& b) {
    p.lo_x[slot] = b.lo[0], p.lo_y[slot] = b.lo[1], p.lo_z[slot] = b.lo[2];
    p.hi_x[slot] = b.hi[0], p.hi_y[slot] = b.hi[1], p.hi_z[slot] = b.hi[2];
  }
  void make_leaf(int parent, int slot, int begin, int n) {
    bvh_.nodes[std::size_t(parent)].child[slot] = begin;
    bvh_.nodes[std::size_t(parent)].count[slot] = n;
  }

  struct Split {
    int axis = -1, bin = -1, mid = 0;
    double cost = std::numeric_limits<double>::infinity();
    float cmin = 0, scale = 0;
  };

  Split median_split(int begin, int end) const {
    Split s;
    s.mid = begin + (end - begin) / 2;
    return s;
  }

  int bin_of(const Split& s, float c) const {
    return std::min(kBins - 1, std::max(0, static_cast<int>((c - s.cmin) * s.scale)));
  }

  // The cheapest of the kBins - 1 planes per axis by the surface area heuristic.
  Split best_split(int begin, int end) const {
    float cmin[3], cmax[3];
    for (int a = 0; a < 3; ++a) cmin[a] = INFINITY, cmax[a] = -INFINITY;
    for (int k = begin; k < end; ++k) {
      const float* c = &centroid_[3 * std::size_t(idx_[std::size_t(k)])];
      for (int a = 0; a < 3; ++a)
        cmin[a] = std::min(cmin[a], c[a]), cmax[a] = std::max(cmax[a], c[a]);
    }
    Box<T> bin_box[3][kBins];
    int bin_count[3][kBins] = {};
    Split probe[3];
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < kBins; ++b) bin_box[a][b] = Box<T>::empty();
      probe[a].cmin = cmin[a];
      const float extent = cmax[a] - cmin[a];
      probe[a].scale = extent > 0 ? float(kBins) / extent * 0.99999f : 0.0f;
    }
    for (int k = begin; k < end; ++k) {
      const std::int32_t i = idx_[std::size_t(k)];
      const float* c = &centroid_[3 * std::size_t(i)];
      for (int a = 0; a < 3; ++a) {
        const int b = bin_of(probe[a], c[a]);
        ++bin_count[a][b];
        bin_box[a][b].grow(boxes_[std::size_t(i)]);
      }
    }
    Split best;
    for (int a = 0; a < 3; ++a) {
      if (!(probe[a].scale > 0)) continue;
      double right_cost[kBins];
      Box<T> acc = Box<T>::empty();
      int count = 0;
      for (int b = kBins - 1; b > 0; --b) {
        acc.grow(bin_box[a][b]);
        count += bin_count[a][b];
        right_cost[b] = count ? acc.half_area() * count : 0.0;
      }
      acc = Box<T>::empty();
      count = 0;
      for (int b = 0; b < kBins - 1; ++b) {
        acc.grow(bin_box[a][b]);
        count += bin_count[a][b];
        if (count == 0 || count == end - begin) continue;
        const double cost = acc.half_area() * count + right_cost[b + 1];
        if (cost < best.cost) {
          best = probe[a];
          best.axis = a, best.bin = b, best.cost = cost;
        }
      }
    }
    // In the units of the leaf cost n * area: a node's traversal costs kTraversalCost tests.
    if (best.axis >= 0) {
      Box<T> all = Box<T>::empty();
      for (int b = 0; b < kBins; ++b) all.grow(bin_box[best.axis][b]);
      best.cost += kTraversalCost * all.half_area();
    }
    return best;
  }

  int partition(int begin, int end, const Split& s) {
    auto first = idx_.begin() + begin, last = idx_.begin() + end;
    auto mid = std::partition(first, last, [&](std::int32_t i) {
      return bin_of(s, centroid_[3 * std::size_t(i) + std::size_t(s.axis)]) <= s.bin;
    });
    return static_cast<int>(mid - idx_.begin());
  }

 private:
  Bvh<T>& bvh_;
  const std::vector<Box<T>>& boxes_;
  const std::vector<float>& centroid_;
  std::vector<std::int32_t>& idx_;
};

// Padding per unit of magnitude: 2^8 ulps of T, far above the rounding of the sphere test
// (a few ulps of |origin - centre|) and of the slab test, so no ray the plain loop finds a sphere
// for misses its box.
template <class T>
constexpr double kPad = std::numeric_limits<T>::epsilon() * 256.0;

}  // namespace

template <class T>
Bvh<T> build_bvh(const std::vector<T>& cx, const std::vector<T>& cy, const std::vector<T>& cz,
                 const std::vector<T>& r, int n, std::vector<std::int32_t>& order) {
  const auto start = std::chrono::steady_clock::now();
  Bvh<T> bvh;
  order.resize(std::size_t(n));
  if (n == 0) return bvh;
  // The camera sits at the origin: rays start at it, on spheres, or on planes (anywhere).
  double reach = 0;
  for (int i = 0; i < n; ++i)
    reach = std::max({reach, std::fabs(double(cx[std::size_t(i)])) + double(r[std::size_t(i)]),
                      std::fabs(double(cy[std::size_t(i)])) + double(r[std::size_t(i)]),
                      std::fabs(double(cz[std::size_t(i)])) + double(r[std::size_t(i)])});
  const double limit = 4.0 * reach;
  bvh.origin_limit = T(limit);
  std::vector<Box<T>> boxes(static_cast<std::size_t>(n));
  std::vector<float> centroid(3 * std::size_t(n));
  Box<T> all = Box<T>::empty();
  for (int i = 0; i < n; ++i) {
    const std::size_t k = std::size_t(i);
    const double c[3] = {double(cx[k]), double(cy[k]), double(cz[k])};
    const double rad = double(r[k]);
    const double big = std::max({std::fabs(c[0]), std::fabs(c[1]), std::fabs(c[2])});
    const double pad = kPad<T> * (limit + big + rad);
    for (int a = 0; a < 3; ++a) {
      boxes[k].lo[a] = T(c[a] - rad - pad);
      boxes[k].hi[a] = T(c[a] + rad + pad);
      centroid[3 * k + std::size_t(a)] = float(c[a]);
    }
    all.grow(boxes[k]);
    order[k] = i;
  }
  bvh.nodes.reserve(std::size_t(n) / 2 + 2);
  Builder<T> builder(bvh, boxes, centroid, order);
  builder.add_node(-1, 0, 0, 1);  // the root holds the two top subtrees' boxes
  if (n == 1) {
    builder.build(0, 0, 0, 1, all, 1);
    builder.build(0, 1, 1, 1, all, 1);  // the empty slot
  } else {
    int mid = n / 2;
    auto s = builder.best_split(0, n);
    if (s.axis >= 0) {
      mid = builder.partition(0, n, s);
      bvh.nodes[0].axis = s.axis;
    }
    builder.build(0, 0, 0, mid, builder.bounds_of(0, mid), 1);
    builder.build(0, 1, mid, n, builder.bounds_of(mid, n), 1);
  }
  LANCER_CHECK(bvh.depth < Bvh<T>::kMaxDepth);
  bvh.build_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return bvh;
}

template struct Bvh<float>;
template struct Bvh<double>;
template Bvh<float> build_bvh<float>(const std::vector<float>&, const std::vector<float>&,
                                     const std::vector<float>&, const std::vector<float>&, int,
                                     std::vector<std::int32_t>&);
template Bvh<double> build_bvh<double>(const std::vector<double>&, const std::vector<double>&,
                                       const std::vector<double>&, const std::vector<double>&, int,
                                       std::vector<std::int32_t>&);

}  // namespace lancer
