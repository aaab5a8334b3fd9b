// Triangles, meshes and cylinders, prepared in the scene's frame and number type T, with a
// bounding volume hierarchy over them for the reference's closest-hit and shadow queries.
//
// Every triangle of every mesh and every cylinder is one primitive; primitives are numbered in
// object-id order, and within a mesh in its file's order, so "the first in the file" of equally
// near hits is the lowest primitive number. The queries' results do not depend on the order the
// hierarchy visits primitives in: the closest hit is the least (t, primitive) pair, and a shadow
// ray's transmittance multiplies the objects met in object-id order.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "lancer/huge_pages.hpp"
#include "lancer/prepared.hpp"
#include "lancer/scene.hpp"
#include "lancer/vec3.hpp"

namespace lancer {

// The surface area in double of the box lo..hi (0 for an empty box): the builds' SAH cost, and
// the collapses into wide and lone nodes, which open the inner child of largest area first.
template <class T>
double surface_area(const T lo[3], const T hi[3]) {
  const double x = double(hi[0]) - lo[0], y = double(hi[1]) - lo[1], z = double(hi[2]) - lo[2];
  return x < 0 ? 0 : 2 * (x * y + y * z + z * x);
}

template <class T>
struct PreparedShapes {
  int first_object = 0;  // the object id of shape 0 (spheres and planes come first)
  int num_shapes = 0;
  // The scene's spheres held as leaves of this hierarchy too, in a scene with both kinds (one
  // hierarchy over every bounded kind: the packets then walk this one, not the spheres' own);
  // 0 where the spheres keep theirs alone. Their ids stay the spheres' (0 .. spheres - 1).
  int spheres = 0;

  // Every mesh's vertices, concatenated, in the frame; each vertex once, so that triangles
  // sharing it read the same bits.
  std::vector<T> vx, vy, vz;
  // Smooth meshes' unit vertex normals, in the frame.
  std::vector<T> nx, ny, nz;

  // Primitives in order: >= 0 a triangle's index, < 0 ~(a cylinder's index).
  std::vector<std::int32_t> prim;
  // Shape k's primitives are those numbered shape_prims[k] .. shape_prims[k + 1] - 1
  // (num_shapes + 1 entries, ascending from 0).
  std::vector<std::int32_t> shape_prims;
  // The object id of primitive p, by a search in the shapes' ranges (num_shapes + 1 entries, in
  // the cache) rather than by prim[p] and tri_object as the reference reads it: incoherent hits
  // find those per-primitive entries out of the cache.
  int prim_object(std::int32_t p) const {
    const auto after = std::upper_bound(shape_prims.begin() + 1, shape_prims.end(), p);
    return first_object + int(after - shape_prims.begin()) - 1;
  }
  // Triangles: 3 vertex indices each, their object id, and, for smooth meshes, 3 normal indices
  // (kNoNormal for flat ones; empty when no mesh is smooth).
  static constexpr std::uint32_t kNoNormal = 0xffffffffu;
  std::vector<std::uint32_t> tri;
  std::vector<std::int32_t> tri_object;
  std::vector<std::uint32_t> tri_normals;
  // Cylinders: base, unit axis, height, squared radius, caps, object id.
  std::vector<Vec3<T>> cyl_base, cyl_axis;
  std::vector<T> cyl_h, cyl_r2;
  std::vector<std::uint8_t> cyl_caps;
  std::vector<std::int32_t> cyl_object;

  // The hierarchy: count > 0 a leaf of order[first .. first+count), else an inner node whose
  // children are nodes first and first + 1. Boxes enclose their primitives' computed bounds.
  struct Node {
    T lo[3], hi[3];
    std::uint32_t first = 0, count = 0;
    double area() const { return surface_area(lo, hi); }
  };
  std::vector<Node> nodes;
  // The tree's items: primitives 0 .. prim.size() - 1, then the spheres (item prim.size() + k
  // is sphere k), which the reference's walks pass over (it meets spheres in their own).
  std::size_t items() const { return prim.size() + std::size_t(spheres); }
  // The tree's depth bound: its walks keep fixed stacks of this many entries.
  static constexpr int kMaxTreeDepth = 128;
  // A leaf's items at most.
  static constexpr int kLeafItems = 4;
  std::vector<std::uint32_t> order;  // items in leaf order

  // The packets' hierarchy: the binary tree above collapsed into kWide-wide nodes (the inner
  // child of largest surface area opened until a node has kWide children), their children's
  // boxes structure-of-arrays, so a packet tests every child of a node per lane. Child slot k <
  // arity: count[k] > 0 the leaf leaves[child[k]] of count[k] items (the binary tree's leaves,
  // unchanged), else the wide node child[k]. order[u], per direction code u (bit
  // a set: the packet's summed direction goes up axis a): the slots by their box centres along
  // that diagonal, nearest first, kOrderBits each; the walk only reorders by it. wide[0] is the
  // root; empty when there are no primitives.
  static constexpr int kWide = 4;
  // The wide boxes are stored grown by kWidePad times their largest |coordinate| (rounded
  // outwards): the box test's margin for the triangle test's reach, whose other share, the
  // same factor of the ray origin's |o|inf, the walk adds (packet/prim/shapes_walk.hpp).
  static constexpr double kWidePad = sizeof(T) == 4 ? 0x1p-18 : 0x1p-47;
  static constexpr int kOrderBits = 2;
  struct alignas(64) WideNode {  // two cache lines (float)
    T lo_x[kWide], hi_x[kWide], lo_y[kWide], hi_y[kWide], lo_z[kWide], hi_z[kWide];
    std::int32_t child[kWide];
    std::uint8_t count[kWide];
    std::uint8_t order[8];
    std::int32_t arity;
  };
  // Offsets (in T, from lo_x) of axis a's lower and upper planes of the children in a WideNode.
  static constexpr int lo_plane(int a) { return 2 * kWide * a; }
  static constexpr int hi_plane(int a) { return 2 * kWide * a + kWide; }
  // The walks' data (wide, leaf) on huge pages where large (lancer/huge_pages.hpp): a mesh of
  // a million triangles spreads them over some 90 MB, beyond 4 KiB pages' reach in the TLB.
  BigVector<WideNode> wide;
  // A wide walk's stack bound: every child of a wide node lies a binary level down or more, so
  // at most kWide - 1 entries per binary level, and one.
  static constexpr int kWideStack = (kWide - 1) * kMaxTreeDepth + 2;
  // One ray's hierarchy (packet/prim/shapes_lone.hpp): the binary tree collapsed into kLone-wide
  // nodes from the root (the inner child of largest area opened until a node has kLone
  // children), lone[0] the root's, each node's inner children side by side after it in a
  // depth-first order. One ray tests a node's eight boxes in one or two registers, so wider nodes
  // take it down in fewer steps. Only the nodes a walk from the root meets are stored (half the
  // memory of a lone node per wide node); a lane handed over at a wide node starts at its
  // LoneEntry.
  // Slot k: count[k] > 0 the leaf child[k] of count[k] items, else lone node child[k]. The same
  // padded boxes as the wide nodes' (padded_box), the same leaves; unused slots have empty boxes
  // (lo +inf, hi -inf), which no ray meets.
  static constexpr int kLone = 8;
  struct alignas(64) LoneNode {  // four cache lines (float)
    T lo_x[kLone], hi_x[kLone], lo_y[kLone], hi_y[kLone], lo_z[kLone], hi_z[kLone];
    std::int32_t child[kLone];
    std::uint8_t count[kLone];
    std::int32_t arity;
  };
  // Where a packet's lanes that go on alone at wide node j start: lone node `node`, its slots
  // `slots` (bits), those under j. Wide node j's subtree is lone node `node` whole where j's
  // binary node starts one, else the slots below it in the lone node it was opened into.
  struct LoneEntry {
    std::int32_t node = 0;
    std::uint32_t slots = 0;
  };
  std::vector<LoneEntry> lone_entry;  // per wide node
  static constexpr int lone_lo_plane(int a) { return 2 * kLone * a; }
  static constexpr int lone_hi_plane(int a) { return 2 * kLone * a + kLone; }
  BigVector<LoneNode> lone;
  // Every lone step goes a binary level down or more, pushing kLone - 1 entries at most.
  static constexpr int kLoneStack = (kLone - 1) * kMaxTreeDepth + 2;
  // The tree's leaves, as both walks read them: every leaf of the binary tree once (kLeafItems
  // items at most), in leaf order; the wide and the lone nodes name a leaf child by its index
  // here. Per leaf, each coordinate of its items' vertices in a row (structure of arrays,
  // Embree's triangle4v): one ray tests a leaf's triangles across a register with one load per
  // coordinate, and a packet broadcasts an item's coordinate from the same lines. Per item its
  // reference (prim's entry; kSphereRef for a sphere) and its hit id less first_object: a
  // primitive's number, a sphere's id less first_object (negative), so that hit ids order as
  // object ids do.
  static constexpr std::int32_t kSphereRef = std::numeric_limits<std::int32_t>::min();
  struct alignas(64) Leaf {  // three cache lines (float)
    // Item k's vertex c, coordinate q at v[3c + q][k] (a triangle's: the bits of vx, vy, vz); a
    // sphere's centre and squared radius at v[0..3][k] (the spheres' block's bits). The rows an
    // item leaves free (a sphere's last five, a cylinder's, those past count) repeat the leaf's
    // first triangle, so that every lane of the one-ray test computes a real triangle's edges
    // (zeros where the leaf has no triangle).
    T v[9][kLeafItems];
    std::int32_t ref[kLeafItems];
    std::int32_t prim[kLeafItems];
    std::uint32_t count = 0;  // items
    std::uint32_t tri = 0;    // bit k: item k is a triangle
  };
  BigVector<Leaf> leaves;
  // Primitive p's place in leaves: leaf prim_leaf[p] / kLeafItems, item prim_leaf[p] %
  // kLeafItems. The library API's hit fields read a hit's reference and vertices there, from the
  // lines the walk has just tested, rather than through prim, tri and the vertex arrays.
  std::vector<std::int32_t> prim_leaf;
  double build_seconds = 0;

  std::size_t triangles() const { return tri_object.size(); }
  std::size_t bytes() const;  // everything above, as allocated
};

// Node b's box (the binary tree's) as the wide and lone nodes store it: grown by kWidePad times
// its largest |coordinate|, rounded outwards.
template <class T>
void padded_box(const typename PreparedShapes<T>::Node& b, T lo[3], T hi[3]) {
  const T inf = std::numeric_limits<T>::infinity();
  double mag = 0;
  for (int a = 0; a < 3; ++a)
    mag = std::max({mag, std::fabs(double(b.lo[a])), std::fabs(double(b.hi[a]))});
  const double pad = PreparedShapes<T>::kWidePad * mag;
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::nextafter(T(double(b.lo[a]) - pad), -inf);
    hi[a] = std::nextafter(T(double(b.hi[a]) + pad), inf);
  }
}

// Binary node `root`'s subtree as at most `most` kids (binary nodes, in depth-first order): its
// two children, then the inner kid of largest area opened into its two (they take its place)
// while there is room; a leaf root is its own only kid. opened(k, n) runs before kid k of n is
// opened (a caller's own per-kid data shifts alike). Returns the kids' count. The one collapse
// of the wide nodes and the lone nodes.
template <class T, class Opened>
int collapse(const std::vector<typename PreparedShapes<T>::Node>& nodes, std::uint32_t root,
             std::uint32_t* kids, int most, Opened&& opened) {
  int n = 0;
  if (nodes[root].count > 0) {
    kids[n++] = root;
  } else {
    kids[n++] = nodes[root].first, kids[n++] = nodes[root].first + 1;
  }
  while (n < most) {
    int open = -1;
    double best = -1;
    for (int k = 0; k < n; ++k) {
      if (nodes[kids[k]].count > 0) continue;
      const double a = nodes[kids[k]].area();
      if (a > best) best = a, open = k;
    }
    if (open < 0) break;
    opened(open, n);
    const std::uint32_t first = nodes[kids[open]].first;
    for (int k = n; k > open + 1; --k) kids[k] = kids[k - 1];
    kids[open] = first, kids[open + 1] = first + 1, ++n;
  }
  return n;
}

// s.lone and s.lone_entry from the binary tree (shapes_lone.cpp). leaf_of: each binary leaf's
// index in s.leaves; wide_binary: each wide node's binary node.
template <class T>
void build_lone(PreparedShapes<T>& s, const std::vector<std::uint32_t>& leaf_of,
                const std::vector<std::uint32_t>& wide_binary);

// The scene's shapes in `frame`, rounded to T once per vertex, and their hierarchy. Object ids
// start at `first_object`. With `spheres` (the scene's, prepared: `num_spheres` of them), the
// hierarchy holds them too.
template <class T>
PreparedShapes<T> prepare_shapes(const Scene& scene, const Frame& frame, int first_object,
                                 const SphereBlock<T>* spheres = nullptr, int num_spheres = 0);

// The nearest primitive hit with epsilon < t < t_limit (ties to the lower primitive number),
// from origin o along unit d: object -1 when none.
template <class T>
struct ShapeHit {
  int object = -1;
  std::int64_t prim = -1;
  T t = 0;
  T part = 0;  // cylinders: prim::kCylinderSide, kCylinderBase or kCylinderTop
};
template <class T>
ShapeHit<T> shapes_closest(const PreparedShapes<T>& s, const Vec3<T>& o, const Vec3<T>& d,
                           T epsilon, T t_limit);

// Primitive `prim`'s hit along o, d beyond epsilon (its object, t and, on a cylinder, the part):
// what shapes_closest returns where that primitive is the nearest. The library API's packets
// find the primitive; this completes its hit.
template <class T>
ShapeHit<T> shape_hit(const PreparedShapes<T>& s, const Vec3<T>& o, const Vec3<T>& d, T epsilon,
                      std::int64_t prim);

// The objects a shadow segment from o along unit l meets before `dist` (a hit with
// epsilon < t < dist), each once, in ascending object id. `stop_at_first`: one is enough (an
// opaque scene), the list then holds at most one.
template <class T>
void shapes_met(const PreparedShapes<T>& s, const Vec3<T>& o, const Vec3<T>& l, T epsilon, T dist,
                bool stop_at_first, std::vector<int>& objects);

// The geometric normal (unit) at the hit, and the shading normal (smooth meshes: the blend of
// the vertex normals; else the geometric one), neither yet turned to the ray.
template <class T>
void shapes_normals(const PreparedShapes<T>& s, const ShapeHit<T>& hit, const Vec3<T>& o,
                    const Vec3<T>& d, const Vec3<T>& p, Vec3<T>& geometric, Vec3<T>& shading);

// Where a hit lies on its primitive, as Embree reports it (the library API's prim_id, u, v):
// the primitive's index within its object (a mesh's triangle in its file order, zero-area ones
// left out as they are when loaded; 0 for a lone triangle or a cylinder), and on a triangle the
// barycentric weights of vertices 1 and 2, so that the hit lies at (1 - u - v) v0 + u v1 + v v2
// (the watertight test's own weights, from the same edge functions); u = v = 0 on a cylinder.
template <class T>
struct ShapeSurface {
  int prim_in_object = 0;
  T u = 0, v = 0;
};
template <class T>
ShapeSurface<T> shapes_surface(const PreparedShapes<T>& s, const ShapeHit<T>& hit, const Vec3<T>& o,
                               const Vec3<T>& d);

extern template PreparedShapes<float> prepare_shapes<float>(const Scene&, const Frame&, int,
                                                            const SphereBlock<float>*, int);
extern template PreparedShapes<double> prepare_shapes<double>(const Scene&, const Frame&, int,
                                                              const SphereBlock<double>*, int);

}  // namespace lancer
