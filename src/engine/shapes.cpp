// Triangles, meshes and cylinders prepared for the reference: the arrays, a binned-SAH hierarchy
// over them, and the closest-hit and shadow queries.
#include "lancer/shapes.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "lancer/huge_pages.hpp"
#include "lancer/prefetch.hpp"
#include "lancer/prim/cylinder.hpp"
#include "lancer/prim/triangle.hpp"
#include "shape_fields.hpp"

namespace lancer {

namespace {

constexpr int kBins = 16;
constexpr std::uint32_t kLeafSize = PreparedShapes<float>::kLeafItems;
constexpr int kMedianDepth = 64;
constexpr int kMaxDepth = PreparedShapes<float>::kMaxTreeDepth;

template <class T>
struct Box {
  T lo[3], hi[3];
  static Box empty() {
    Box b;
    for (int k = 0; k < 3; ++k)
      b.lo[k] = std::numeric_limits<T>::infinity(), b.hi[k] = -std::numeric_limits<T>::infinity();
    return b;
  }
  void grow(const Box& o) {
    for (int k = 0; k < 3; ++k) b_min(lo[k], o.lo[k]), b_max(hi[k], o.hi[k]);
  }
  static void b_min(T& a, T b) { a = b < a ? b : a; }
  static void b_max(T& a, T b) { a = b > a ? b : a; }
  double area() const { return surface_area(lo, hi); }
  double centre(int k) const { return 0.5 * (double(lo[k]) + double(hi[k])); }
};

// A cylinder's box in double (each end's disc spans r sqrt(1 - a_k^2) along axis k), rounded
// outwards to T.
template <class T>
Box<T> cylinder_box(const Cylinder& c, const Frame& frame) {
  const Vec3<double> a = frame.point(c.base), b = frame.point(c.top);
  const Vec3<double> axis = normalize(b - a);
  const double ak[3] = {axis.x, axis.y, axis.z}, pa[3] = {a.x, a.y, a.z}, pb[3] = {b.x, b.y, b.z};
  Box<T> box;
  for (int k = 0; k < 3; ++k) {
    const double reach =
        c.radius * std::sqrt(std::max(0.0, 1 - ak[k] * ak[k])) * (1 + 1e-12) + 1e-300;
    const double lo = std::min(pa[k], pb[k]) - reach, hi = std::max(pa[k], pb[k]) + reach;
    box.lo[k] = std::nextafter(T(lo), -std::numeric_limits<T>::infinity());
    box.hi[k] = std::nextafter(T(hi), std::numeric_limits<T>::infinity());
  }
  return box;
}

// Sphere k's box: its centre -+ its radius, in double, grown by 2^-20 of the radius and rounded
// outwards to T (the packets' walk adds the margins for the test's rounding; shapes_walk.hpp).
template <class T>
Box<T> sphere_box(const SphereBlock<T>& sp, std::size_t k) {
  const double c[3] = {double(sp.cx[k]), double(sp.cy[k]), double(sp.cz[k])};
  const double reach = std::sqrt(double(sp.r2[k])) * (1 + 0x1p-20) + 1e-300;
  Box<T> box;
  for (int a = 0; a < 3; ++a) {
    box.lo[a] = std::nextafter(T(c[a] - reach), -std::numeric_limits<T>::infinity());
    box.hi[a] = std::nextafter(T(c[a] + reach), std::numeric_limits<T>::infinity());
  }
  return box;
}

// Binned SAH over primitive boxes; children of a node are stored side by side.
template <class T>
void build_hierarchy(PreparedShapes<T>& s, const std::vector<Box<T>>& boxes) {
  using Node = typename PreparedShapes<T>::Node;
  const std::uint32_t n = static_cast<std::uint32_t>(boxes.size());
  s.order.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) s.order[i] = i;
  s.nodes.clear();
  s.nodes.reserve(std::size_t(2) * n / kLeafSize + 2);
  s.nodes.emplace_back();
  struct Task {
    std::uint32_t node, first, count;
    int depth;
  };
  std::vector<Task> stack{{0, 0, n, 0}};
  while (!stack.empty()) {
    const Task task = stack.back();
    stack.pop_back();
    Box<T> box = Box<T>::empty(), cbox = Box<T>::empty();
    for (std::uint32_t i = task.first; i < task.first + task.count; ++i) {
      const Box<T>& b = boxes[s.order[i]];
      box.grow(b);
      for (int k = 0; k < 3; ++k) {
        const T c = T(b.centre(k));
        Box<T>::b_min(cbox.lo[k], c), Box<T>::b_max(cbox.hi[k], c);
      }
    }
    Node& node = s.nodes[task.node];
    for (int k = 0; k < 3; ++k) node.lo[k] = box.lo[k], node.hi[k] = box.hi[k];
    node.first = task.first, node.count = task.count;
    if (task.count <= kLeafSize) continue;
    int axis = 0;
    double extent = -1;
    for (int k = 0; k < 3; ++k)
      if (double(cbox.hi[k]) - cbox.lo[k] > extent)
        extent = double(cbox.hi[k]) - cbox.lo[k], axis = k;
    std::uint32_t mid = task.first + task.count / 2;
    auto* begin = s.order.data() + task.first;
    auto* end = begin + task.count;
    // Past kMedianDepth the split is the median (depth then grows by log2 of the count at
    // most), so the walks' fixed stacks of kMaxDepth entries always suffice.
    if (extent > 0 && task.depth < kMedianDepth) {
      Box<T> bin_box[kBins];
      std::uint32_t bin_count[kBins] = {};
      for (auto& b : bin_box) b = Box<T>::empty();
      const double lo = cbox.lo[axis], scale = kBins / extent;
      // Clamped at both ends: the centres' bounds were rounded to T, so a centre (in double)
      // may lie a rounding below lo, which the scale of a narrow spread turns into a bin of -1.
      auto bin_of = [&](std::uint32_t p) {
        const double x = (boxes[p].centre(axis) - lo) * scale;
        return int(std::clamp(x, 0.0, double(kBins - 1)));
      };
      for (auto* it = begin; it != end; ++it) {
        const int b = bin_of(*it);
        bin_box[b].grow(boxes[*it]), ++bin_count[b];
      }
      double right_area[kBins];
      std::uint32_t right_count[kBins];
      Box<T> acc = Box<T>::empty();
      std::uint32_t cnt = 0;
      for (int b = kBins - 1; b > 0; --b) {
        acc.grow(bin_box[b]), cnt += bin_count[b];
        right_area[b] = acc.area(), right_count[b] = cnt;
      }
      acc = Box<T>::empty(), cnt = 0;
      double best = std::numeric_limits<double>::infinity();
      int split = -1;
      for (int b = 1; b < kBins; ++b) {
        acc.grow(bin_box[b - 1]), cnt += bin_count[b - 1];
        if (cnt == 0 || right_count[b] == 0) continue;
        const double cost = acc.area() * cnt + right_area[b] * right_count[b];
        if (cost < best) best = cost, split = b;
      }
      if (split > 0 && split < kBins) {
        auto* m = std::partition(begin, end, [&](std::uint32_t p) { return bin_of(p) < split; });
        mid = static_cast<std::uint32_t>(m - s.order.data());
      } else {
        extent = 0;
      }
    }
    if (!(extent > 0 && task.depth < kMedianDepth) || mid == task.first ||
        mid == task.first + task.count) {
      mid = task.first + task.count / 2;
      std::nth_element(begin, begin + task.count / 2, end, [&](std::uint32_t a, std::uint32_t b) {
        return boxes[a].centre(axis) < boxes[b].centre(axis);
      });
    }
    const std::uint32_t left = static_cast<std::uint32_t>(s.nodes.size());
    s.nodes.emplace_back(), s.nodes.emplace_back();
    Node& parent = s.nodes[task.node];  // emplace_back may have moved it
    parent.first = left, parent.count = 0;
    stack.push_back({left, task.first, mid - task.first, task.depth + 1});
    stack.push_back({left + 1, mid, task.first + task.count - mid, task.depth + 1});
  }
}

// The binary tree's leaves as the walks read them (PreparedShapes::leaves), in leaf order (the
// spheres' from `spheres`); returns each binary node's leaf index (leaves only).
template <class T>
std::vector<std::uint32_t> build_leaves(PreparedShapes<T>& s, const SphereBlock<T>* spheres) {
  using Shapes = PreparedShapes<T>;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> firsts;  // (first, node)
  for (std::uint32_t i = 0; i < s.nodes.size(); ++i)
    if (s.nodes[i].count > 0) firsts.push_back({s.nodes[i].first, i});
  std::sort(firsts.begin(), firsts.end());
  std::vector<std::uint32_t> leaf_of(s.nodes.size(), 0);
  s.leaves.assign(firsts.size(), typename Shapes::Leaf{});
  s.prim_leaf.assign(s.prim.size(), -1);
  for (std::size_t i = 0; i < firsts.size(); ++i) {
    const auto& node = s.nodes[firsts[i].second];
    leaf_of[firsts[i].second] = std::uint32_t(i);
    auto& l = s.leaves[i];
    l.count = node.count;
    int rows[Shapes::kLeafItems] = {};  // the rows item k fills
    for (std::uint32_t k = 0; k < node.count; ++k) {
      const std::uint32_t item = s.order[node.first + k];
      if (item >= s.prim.size()) {  // a sphere
        const std::size_t j = item - s.prim.size();
        l.ref[k] = Shapes::kSphereRef;
        l.prim[k] = std::int32_t(j) - s.first_object;
        const T c[4] = {spheres->cx[j], spheres->cy[j], spheres->cz[j], spheres->r2[j]};
        for (int q = 0; q < 4; ++q) l.v[q][k] = c[q];
        rows[k] = 4;
        continue;
      }
      l.prim[k] = std::int32_t(item);
      l.ref[k] = s.prim[item];
      s.prim_leaf[item] = std::int32_t(i) * Shapes::kLeafItems + std::int32_t(k);
      if (l.ref[k] < 0) continue;
      l.tri |= 1u << k, rows[k] = 9;
      for (int c = 0; c < 3; ++c) {
        const std::uint32_t v = s.tri[3 * std::size_t(l.ref[k]) + std::size_t(c)];
        l.v[3 * c][k] = s.vx[v], l.v[3 * c + 1][k] = s.vy[v], l.v[3 * c + 2][k] = s.vz[v];
      }
    }
    const int copy = l.tri != 0 ? __builtin_ctz(l.tri) : -1;
    for (int k = 0; k < Shapes::kLeafItems; ++k)
      for (int q = rows[k]; q < 9; ++q) l.v[q][k] = copy < 0 ? T(0) : l.v[q][copy];
  }
  return leaf_of;
}

// The binary tree collapsed into wide nodes (PreparedShapes::wide), over the leaves
// (build_leaves; the spheres' from `spheres`). leaf_of: each binary leaf's index in s.leaves;
// wide_binary: each wide node's binary node.
template <class T>
void build_wide(PreparedShapes<T>& s, const SphereBlock<T>* spheres,
                std::vector<std::uint32_t>& leaf_of, std::vector<std::uint32_t>& wide_binary) {
  using Shapes = PreparedShapes<T>;
  using Wide = typename Shapes::WideNode;
  constexpr int kW = Shapes::kWide;
  s.wide.clear(), s.leaves.clear(), wide_binary.clear();
  if (s.order.empty()) return;
  leaf_of = build_leaves(s, spheres);
  struct Job {
    std::uint32_t binary, wide;
  };
  std::vector<Job> jobs{{0, 0}};
  s.wide.emplace_back();
  wide_binary.push_back(0);
  while (!jobs.empty()) {
    const Job job = jobs.back();
    jobs.pop_back();
    // The children, in the binary tree's depth-first order: the inner one of largest area
    // opened into its two until there are kW (a leaf root: itself, alone).
    std::uint32_t kids[kW];
    const int n = collapse<T>(s.nodes, job.binary, kids, kW, [](int, int) {});
    Wide w{};
    w.arity = n;
    double centre[kW][3];
    for (int k = 0; k < kW; ++k) {
      const T inf = std::numeric_limits<T>::infinity();
      w.lo_x[k] = w.lo_y[k] = w.lo_z[k] = inf, w.hi_x[k] = w.hi_y[k] = w.hi_z[k] = -inf;
      w.child[k] = -1;
      if (k >= n) continue;
      const auto& b = s.nodes[kids[k]];
      T lo[3], hi[3];
      padded_box<T>(b, lo, hi);
      w.lo_x[k] = lo[0], w.lo_y[k] = lo[1], w.lo_z[k] = lo[2];
      w.hi_x[k] = hi[0], w.hi_y[k] = hi[1], w.hi_z[k] = hi[2];
      for (int a = 0; a < 3; ++a) centre[k][a] = 0.5 * (double(b.lo[a]) + double(b.hi[a]));
      if (b.count > 0) {
        w.child[k] = std::int32_t(leaf_of[kids[k]]), w.count[k] = std::uint8_t(b.count);
      } else {
        w.child[k] = std::int32_t(s.wide.size()), w.count[k] = 0;
        jobs.push_back({kids[k], std::uint32_t(s.wide.size())});
        s.wide.emplace_back();
        wide_binary.push_back(kids[k]);
      }
    }
    for (unsigned code = 0; code < 8; ++code) {
      int slot[kW] = {0, 1, 2, 3};
      double key[kW];
      for (int k = 0; k < n; ++k) {
        key[k] = 0;
        for (int a = 0; a < 3; ++a) key[k] += (code >> a & 1u ? 1 : -1) * centre[k][a];
      }
      std::stable_sort(slot, slot + n, [&](int a, int b) { return key[a] < key[b]; });
      unsigned packed = 0;
      for (int p = 0; p < kW; ++p) packed |= unsigned(slot[p]) << (Shapes::kOrderBits * p);
      w.order[code] = std::uint8_t(packed);
    }
    s.wide[job.wide] = w;
  }
}

// The slab test in double, never turning away a ray the primitive tests would accept. Two
// margins: the box's entry and exit carry three roundings each, covered by widening [t0, t1]
// by a few ulps of double (Ize, "Robust BVH Ray Traversal", JCGT 2013); and the watertight
// triangle test, in T, accepts rays that pass outside the triangle by a few ulps of T of the
// vertices relative to the origin (its edge functions round; an edge is included), so each box
// grows by 2^-19 (float; 2^-48 for double) of |origin|inf + |box|inf, some 30 times that.
struct SlabRay {
  double o[3], inv[3];
  bool zero[3];
  double o_mag = 0, pad_rel;
  template <class T>
  explicit SlabRay(const Vec3<T>& org, const Vec3<T>& dir)
      : pad_rel(sizeof(T) == 4 ? 0x1p-19 : 0x1p-48) {
    const T od[3] = {org.x, org.y, org.z}, dd[3] = {dir.x, dir.y, dir.z};
    for (int k = 0; k < 3; ++k) {
      o[k] = double(od[k]);
      o_mag = std::max(o_mag, std::fabs(o[k]));
      zero[k] = dd[k] == T(0);
      inv[k] = zero[k] ? 0 : 1.0 / double(dd[k]);
    }
  }
  // Whether [0, t_max] along the ray meets the box (t_max inclusive: a tie may still win).
  template <class T>
  bool meets(const T lo_t[3], const T hi_t[3], double t_max) const {
    double mag = 0;
    for (int k = 0; k < 3; ++k)
      mag = std::max({mag, std::fabs(double(lo_t[k])), std::fabs(double(hi_t[k]))});
    const double pad = pad_rel * (o_mag + mag);
    double lo[3], hi[3];
    for (int k = 0; k < 3; ++k) lo[k] = double(lo_t[k]) - pad, hi[k] = double(hi_t[k]) + pad;
    double t0 = 0, t1 = t_max * (1 + 0x1p-50);
    for (int k = 0; k < 3; ++k) {
      if (zero[k]) {
        if (o[k] < lo[k] || o[k] > hi[k]) return false;
        continue;
      }
      double a = (lo[k] - o[k]) * inv[k], b = (hi[k] - o[k]) * inv[k];
      if (a > b) std::swap(a, b);
      t0 = std::max(t0, a * (1 - 0x1p-50));
      t1 = std::min(t1, b * (1 + 0x1p-50));
      if (t0 > t1) return false;
    }
    return true;
  }
};

// Triangle t's vertices (vx, vy, vz's bits).
template <class T>
std::array<Vec3<T>, 3> triangle_vertices(const PreparedShapes<T>& s, std::uint32_t t) {
  const std::uint32_t* v = &s.tri[3 * std::size_t(t)];
  std::array<Vec3<T>, 3> out;
  for (int c = 0; c < 3; ++c) out[std::size_t(c)] = {s.vx[v[c]], s.vy[v[c]], s.vz[v[c]]};
  return out;
}

// One ray's view of the primitives: the shear for triangles, and the tests.
template <class T>
struct PrimRay {
  const PreparedShapes<T>& s;
  Vec3<T> o, d;
  prim::RayShear<T> shear;
  T eps;

  PrimRay(const PreparedShapes<T>& shapes, const Vec3<T>& org, const Vec3<T>& dir, T epsilon)
      : s(shapes), o(org), d(dir), shear(prim::ray_shear(dir)), eps(epsilon) {}

  prim::TriangleEdges<T> edges(std::uint32_t t) const { return edges(triangle_vertices(s, t)); }
  // The edges of the triangle of vertices v, taken relative to the ray's origin.
  prim::TriangleEdges<T> edges(const std::array<Vec3<T>, 3>& v) const {
    return prim::triangle_edges<T>(prim::permuted(v[0] - o, shear), prim::permuted(v[1] - o, shear),
                                   prim::permuted(v[2] - o, shear), shear.sx, shear.sy, shear.sz);
  }
  // The primitive's nearest hit beyond epsilon (infinity for none) and its part.
  prim::CylinderHit<T> hit(std::int32_t ref) const {
    const T inf = std::numeric_limits<T>::infinity();
    if (ref >= 0) {
      const prim::TriangleEdges<T> e = edges(std::uint32_t(ref));
      if (!prim::triangle_inside(e)) return {inf, T(0)};
      const T t = prim::triangle_t(e);
      return {t > eps ? t : inf, T(0)};
    }
    const std::size_t c = std::size_t(~ref);
    return prim::cylinder_closest(o - s.cyl_base[c], d, s.cyl_axis[c], s.cyl_h[c], s.cyl_r2[c],
                                  s.cyl_caps[c] != 0, eps);
  }
  int object(std::int32_t ref) const {
    return ref >= 0 ? s.tri_object[std::size_t(ref)] : s.cyl_object[std::size_t(~ref)];
  }
};

// Visits the leaves whose boxes [0, limit()] meets, depth first; `leaf(first, count)` returns
// true to stop.
template <class T, class Limit, class Leaf>
void walk(const PreparedShapes<T>& s, const SlabRay& slab, Limit limit, Leaf leaf) {
  if (s.nodes.empty()) return;
  std::uint32_t stack[kMaxDepth];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const auto& node = s.nodes[stack[--top]];
    if (!slab.meets(node.lo, node.hi, limit())) continue;
    if (node.count > 0) {
      if (leaf(node.first, node.count)) return;
      continue;
    }
    stack[top++] = node.first + 1;
    stack[top++] = node.first;
  }
}

}  // namespace

template <class T>
std::size_t PreparedShapes<T>::bytes() const {
  return (vx.capacity() + vy.capacity() + vz.capacity() + nx.capacity() + ny.capacity() +
          nz.capacity() + cyl_h.capacity() + cyl_r2.capacity()) *
             sizeof(T) +
         (prim.capacity() + tri.capacity() + tri_object.capacity() + tri_normals.capacity() +
          cyl_object.capacity() + order.capacity() + shape_prims.capacity() +
          prim_leaf.capacity()) *
             4 +
         (cyl_base.capacity() + cyl_axis.capacity()) * sizeof(Vec3<T>) + cyl_caps.capacity() +
         nodes.capacity() * sizeof(Node) + wide.capacity() * sizeof(WideNode) +
         lone.capacity() * sizeof(LoneNode) + lone_entry.capacity() * sizeof(LoneEntry) +
         leaves.capacity() * sizeof(Leaf);
}

template <class T>
PreparedShapes<T> prepare_shapes(const Scene& scene, const Frame& frame, int first_object,
                                 const SphereBlock<T>* spheres, int num_spheres) {
  const auto start = std::chrono::steady_clock::now();
  PreparedShapes<T> s;
  s.first_object = first_object;
  s.num_shapes = static_cast<int>(scene.shapes.size());
  s.spheres = spheres ? num_spheres : 0;
  std::size_t nv = 0, nt = 0, nn = 0, nc = 0;
  bool smooth = false;
  for (const Shape& sh : scene.shapes) {
    nv += sh.mesh.vertices.size(), nt += sh.mesh.triangles(), nn += sh.mesh.normals.size();
    nc += sh.kind == Shape::Kind::cylinder;
    smooth = smooth || sh.mesh.smooth;
  }
  // On huge pages where large (lancer/huge_pages.hpp): the hits of a mesh of millions of
  // triangles read them all over, a page-table walk each on 4 KiB pages.
  for (auto* v : {&s.vx, &s.vy, &s.vz}) reserve_prepared(*v, nv);
  for (auto* v : {&s.nx, &s.ny, &s.nz}) reserve_prepared(*v, nn);
  reserve_prepared(s.tri, 3 * nt);
  reserve_prepared(s.tri_object, nt);
  if (smooth) reserve_prepared(s.tri_normals, 3 * nt);
  reserve_prepared(s.prim, nt + nc);
  std::vector<Box<T>> boxes;
  boxes.reserve(nt + nc + std::size_t(s.spheres));
  s.shape_prims.reserve(std::size_t(s.num_shapes) + 1);
  for (int k = 0; k < s.num_shapes; ++k) {
    const Shape& sh = scene.shapes[std::size_t(k)];
    const int object = first_object + k;
    s.shape_prims.push_back(std::int32_t(s.prim.size()));
    if (sh.kind == Shape::Kind::cylinder) {
      const Cylinder& c = sh.cylinder;
      const Vec3<double> a = frame.point(c.base), b = frame.point(c.top);
      const Vec3<double> axis = frame.direction(normalize(c.top - c.base));
      s.cyl_base.push_back(Vec3<T>::from(a));
      s.cyl_axis.push_back(Vec3<T>::from(axis));
      s.cyl_h.push_back(T(length(b - a)));
      s.cyl_r2.push_back(T(c.radius) * T(c.radius));
      s.cyl_caps.push_back(c.caps ? 1 : 0);
      s.cyl_object.push_back(object);
      s.prim.push_back(~std::int32_t(s.cyl_object.size() - 1));
      boxes.push_back(cylinder_box<T>(c, frame));
      continue;
    }
    const Mesh& m = sh.mesh;
    const std::uint32_t base = static_cast<std::uint32_t>(s.vx.size());
    for (const Vec3<double>& v : m.vertices) {
      const Vec3<double> p = frame.point(v);
      s.vx.push_back(T(p.x)), s.vy.push_back(T(p.y)), s.vz.push_back(T(p.z));
    }
    const std::uint32_t nbase = static_cast<std::uint32_t>(s.nx.size());
    for (const Vec3<double>& n : m.normals) {
      const Vec3<double> r = frame.direction(n);
      s.nx.push_back(T(r.x)), s.ny.push_back(T(r.y)), s.nz.push_back(T(r.z));
    }
    for (std::size_t t = 0; t < m.triangles(); ++t) {
      Box<T> box = Box<T>::empty();
      for (int c = 0; c < 3; ++c) {
        const std::uint32_t v = base + m.indices[3 * t + std::size_t(c)];
        s.tri.push_back(v);
        const T p[3] = {s.vx[v], s.vy[v], s.vz[v]};
        for (int a = 0; a < 3; ++a) Box<T>::b_min(box.lo[a], p[a]), Box<T>::b_max(box.hi[a], p[a]);
        if (smooth)
          s.tri_normals.push_back(m.smooth ? nbase + m.normal_indices[3 * t + std::size_t(c)]
                                           : PreparedShapes<T>::kNoNormal);
      }
      s.prim.push_back(static_cast<std::int32_t>(s.tri_object.size()));
      s.tri_object.push_back(object);
      boxes.push_back(box);
    }
  }
  s.shape_prims.push_back(std::int32_t(s.prim.size()));
  for (int k = 0; k < s.spheres; ++k) boxes.push_back(sphere_box(*spheres, std::size_t(k)));
  build_hierarchy(s, boxes);
  std::vector<std::uint32_t> leaf_of, wide_binary;
  build_wide(s, spheres, leaf_of, wide_binary);
  build_lone(s, leaf_of, wide_binary);
  s.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return s;
}

template <class T>
ShapeHit<T> shapes_closest(const PreparedShapes<T>& s, const Vec3<T>& o, const Vec3<T>& d,
                           T epsilon, T t_limit) {
  ShapeHit<T> best;
  best.t = t_limit;
  const PrimRay<T> ray(s, o, d, epsilon);
  const SlabRay slab(o, d);
  walk(
      s, slab, [&] { return double(best.t); },
      [&](std::uint32_t first, std::uint32_t count) {
        for (std::uint32_t j = first; j < first + count; ++j) {
          const std::uint32_t p = s.order[j];
          if (p >= s.prim.size()) continue;  // a sphere: the reference meets it in its own
          const prim::CylinderHit<T> h = ray.hit(s.prim[p]);
          // Strictly nearer than t_limit; among shapes, an equal t keeps the lower primitive.
          if (h.t < best.t || (h.t == best.t && best.prim >= 0 && std::int64_t(p) < best.prim))
            best = {ray.object(s.prim[p]), std::int64_t(p), h.t, h.part};
        }
        return false;
      });
  return best;
}

template <class T>
ShapeHit<T> shape_hit(const PreparedShapes<T>& s, const Vec3<T>& o, const Vec3<T>& d, T epsilon,
                      std::int64_t prim) {
  const PrimRay<T> ray(s, o, d, epsilon);
  const std::int32_t ref = s.prim[std::size_t(prim)];
  const prim::CylinderHit<T> h = ray.hit(ref);
  return {ray.object(ref), prim, h.t, h.part};
}

template <class T>
void shapes_met(const PreparedShapes<T>& s, const Vec3<T>& o, const Vec3<T>& l, T epsilon, T dist,
                bool stop_at_first, std::vector<int>& objects) {
  objects.clear();
  const PrimRay<T> ray(s, o, l, epsilon);
  const SlabRay slab(o, l);
  walk(
      s, slab, [&] { return double(dist); },
      [&](std::uint32_t first, std::uint32_t count) {
        for (std::uint32_t j = first; j < first + count; ++j) {
          const std::uint32_t p = s.order[j];
          if (p >= s.prim.size()) continue;  // a sphere: the reference meets it in its own
          const int object = ray.object(s.prim[p]);
          if (std::find(objects.begin(), objects.end(), object) != objects.end()) continue;
          if (ray.hit(s.prim[p]).t < dist) {
            objects.push_back(object);
            if (stop_at_first) return true;
          }
        }
        return false;
      });
  std::sort(objects.begin(), objects.end());
}

namespace {
// The geometric normal at p of the primitive `ref` (a triangle >= 0, else ~cylinder; part: the
// cylinder's part hit).
template <class T>
Vec3<T> geometric_normal(const PreparedShapes<T>& s, std::int32_t ref, const Vec3<T>& p, T part) {
  if (ref < 0) {
    const std::size_t c = std::size_t(~ref);
    return prim::cylinder_normal(p, s.cyl_base[c], s.cyl_axis[c], part);
  }
  const std::array<Vec3<T>, 3> v = triangle_vertices(s, std::uint32_t(ref));
  return prim::triangle_normal(v[0], v[1], v[2]);
}
}  // namespace

template <class T>
void shapes_normals(const PreparedShapes<T>& s, const ShapeHit<T>& hit, const Vec3<T>& o,
                    const Vec3<T>& d, const Vec3<T>& p, Vec3<T>& geometric, Vec3<T>& shading) {
  const std::int32_t ref = s.prim[std::size_t(hit.prim)];
  geometric = geometric_normal(s, ref, p, hit.part);
  shading = geometric;
  if (ref < 0) return;
  const std::size_t t = std::size_t(ref);
  if (s.tri_normals.empty() || s.tri_normals[3 * t] == PreparedShapes<T>::kNoNormal) return;
  const PrimRay<T> ray(s, o, d, T(0));
  const Vec3<T> bary = prim::triangle_barycentrics(ray.edges(std::uint32_t(t)));
  auto normal = [&](int c) {
    const std::uint32_t k = s.tri_normals[3 * t + std::size_t(c)];
    return Vec3<T>{s.nx[k], s.ny[k], s.nz[k]};
  };
  shading = prim::smooth_normal(bary, normal(0), normal(1), normal(2), geometric);
}

namespace {
// Triangle ref's surface fields for the ray o, d, its vertices v and the index of its object's
// first triangle given.
template <class T>
ShapeSurface<T> triangle_surface(const PreparedShapes<T>& s, std::int32_t ref, std::int32_t first,
                                 const std::array<Vec3<T>, 3>& v, const Vec3<T>& o,
                                 const Vec3<T>& d) {
  ShapeSurface<T> out;
  out.prim_in_object = static_cast<int>(ref - first);
  const PrimRay<T> ray(s, o, d, T(0));
  const Vec3<T> bary = prim::triangle_barycentrics(ray.edges(v));
  out.u = bary.y, out.v = bary.z;
  return out;
}
}  // namespace

template <class T>
ShapeSurface<T> shapes_surface(const PreparedShapes<T>& s, const ShapeHit<T>& hit, const Vec3<T>& o,
                               const Vec3<T>& d) {
  const std::int32_t ref = s.prim[std::size_t(hit.prim)];
  if (ref < 0) return {};  // a cylinder: one primitive, no surface coordinates
  // Triangles are stored in object order, so an object's first is the first with its id.
  const auto& objects = s.tri_object;
  const auto first = std::lower_bound(objects.begin(), objects.end(), objects[std::size_t(ref)]);
  return triangle_surface(s, ref, std::int32_t(first - objects.begin()),
                          triangle_vertices(s, std::uint32_t(ref)), o, d);
}

template <class T>
std::vector<std::int32_t> first_triangles(const PreparedShapes<T>& s) {
  // One slot per shape (object id - first_object): the spheres and planes before them have none.
  std::vector<std::int32_t> first(std::size_t(s.num_shapes), -1);
  for (std::size_t k = s.tri_object.size(); k-- > 0;)
    first[std::size_t(s.tri_object[k] - s.first_object)] = std::int32_t(k);
  return first;
}

template <class T>
ShapeFields<T> shape_fields(const PreparedShapes<T>& s, const std::int32_t* first_triangle,
                            const Vec3<T>& o, const Vec3<T>& d, T t, T epsilon, std::int64_t prim,
                            std::int32_t object) {
  constexpr int kItems = PreparedShapes<T>::kLeafItems;
  const std::int32_t at = s.prim_leaf[std::size_t(prim)];
  const auto& leaf = s.leaves[std::size_t(at / kItems)];
  const int k = at % kItems;
  const std::int32_t ref = leaf.ref[k];
  ShapeFields<T> f;
  if (ref < 0) {
    // A cylinder: one primitive without surface coordinates, whose normal depends on the point
    // and on the part hit, which only its test says.
    const T part = shape_hit(s, o, d, epsilon, prim).part;
    f.geometric = geometric_normal(s, ref, along(o, d, t), part);
    return f;
  }
  // From the leaf's copy of the vertices (vx, vy, vz's bits); the first triangle from the table.
  std::array<Vec3<T>, 3> v;
  for (int c = 0; c < 3; ++c)
    v[std::size_t(c)] = {leaf.v[3 * c][k], leaf.v[3 * c + 1][k], leaf.v[3 * c + 2][k]};
  const std::int32_t first = first_triangle[std::size_t(object - s.first_object)];
  f.surface = triangle_surface(s, ref, first, v, o, d);
  f.geometric = prim::triangle_normal(v[0], v[1], v[2]);  // a triangle's: the same everywhere
  return f;
}

template <class T>
void fetch_shape_fields(const PreparedShapes<T>& s, const std::int32_t* prims, int n) noexcept {
  constexpr int kItems = PreparedShapes<T>::kLeafItems;
  for (int k = 0; k < n; ++k)
    prefetch_lines(&s.leaves[std::size_t(s.prim_leaf[std::size_t(prims[k])] / kItems)],
                   sizeof(s.leaves[0]));
}

#define LANCER_SHAPES(T)                                                                           \
  template struct PreparedShapes<T>;                                                               \
  template PreparedShapes<T> prepare_shapes<T>(const Scene&, const Frame&, int,                    \
                                               const SphereBlock<T>*, int);                        \
  template ShapeHit<T> shapes_closest<T>(const PreparedShapes<T>&, const Vec3<T>&, const Vec3<T>&, \
                                         T, T);                                                    \
  template ShapeHit<T> shape_hit<T>(const PreparedShapes<T>&, const Vec3<T>&, const Vec3<T>&, T,   \
                                    std::int64_t);                                                 \
  template void shapes_met<T>(const PreparedShapes<T>&, const Vec3<T>&, const Vec3<T>&, T, T,      \
                              bool, std::vector<int>&);                                            \
  template void shapes_normals<T>(const PreparedShapes<T>&, const ShapeHit<T>&, const Vec3<T>&,    \
                                  const Vec3<T>&, const Vec3<T>&, Vec3<T>&, Vec3<T>&);             \
  template ShapeSurface<T> shapes_surface<T>(const PreparedShapes<T>&, const ShapeHit<T>&,         \
                                             const Vec3<T>&, const Vec3<T>&);                      \
  template std::vector<std::int32_t> first_triangles<T>(const PreparedShapes<T>&);                 \
  template ShapeFields<T> shape_fields<T>(const PreparedShapes<T>&, const std::int32_t*,           \
                                          const Vec3<T>&, const Vec3<T>&, T, T, std::int64_t,      \
                                          std::int32_t);                                           \
  template void fetch_shape_fields<T>(const PreparedShapes<T>&, const std::int32_t*, int) noexcept;
LANCER_SHAPES(float)
LANCER_SHAPES(double)
#undef LANCER_SHAPES

}  // namespace lancer
