// Triangles, meshes and cylinders in the reference: watertightness at every shared edge and
// vertex, cylinders against an independent long double computation, smooth normals, ties and
// shadow rays through a mesh.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <random>
#include <tuple>

#include "lancer/generate.hpp"
#include "lancer/mesh_io.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/prepared.hpp"
#include "lancer/reference.hpp"
#include "lancer/render.hpp"
#include "lancer/scene.hpp"
#include "lancer/shapes.hpp"
#include "support/prims_meshes.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

using namespace prims_test;

struct LeakCount {
  std::size_t rays = 0, leaks = 0, edges = 0;
  // Per packet width this CPU runs (exact float or double kernels): the same rays' leaks.
  std::map<int, std::size_t> packet_leaks;
  std::map<int, std::size_t> packet_differs;  // hits not the reference's (id and t's bits)
};

// Rays through points of every edge shared by exactly two triangles (edges found by their
// vertices' coordinates, so a triangle soup counts too) and through every vertex whose
// triangles all face one way of the ray, each crossing the surface there (never grazing it),
// from outside the mesh's bounding sphere. The ray must hit the mesh at or before that point: a
// miss or a later hit is a leak.
template <class T>
LeakCount count_leaks(const Scene& scene, std::uint64_t seed, int points_per_edge) {
  const PreparedScene<T> p = prepare<T>(scene);
  const Mesh& m = scene.shapes[0].mesh;
  // The vertices as the prepared scene holds them (its frame is the world's): rounded to T, so
  // that the edges aimed at are the ones traced.
  std::vector<Vec3<double>> vertices;
  for (const Vec3<double>& v : m.vertices)
    vertices.push_back({double(T(v.x)), double(T(v.y)), double(T(v.z))});
  using Key = std::tuple<double, double, double>;
  auto key = [&](std::uint32_t i) {
    const Vec3<double>& v = vertices[i];
    return Key{v.x, v.y, v.z};
  };
  std::map<std::pair<Key, Key>, std::vector<std::size_t>> edges;
  std::map<Key, std::vector<std::size_t>> fans;
  std::vector<Vec3<double>> normals(m.triangles());
  Vec3<double> lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const Vec3<double>& v : vertices) {
    lo = {std::min(lo.x, v.x), std::min(lo.y, v.y), std::min(lo.z, v.z)};
    hi = {std::max(hi.x, v.x), std::max(hi.y, v.y), std::max(hi.z, v.z)};
  }
  const double reach = 2 * length(hi - lo) + 1;
  for (std::size_t t = 0; t < m.triangles(); ++t) {
    const std::uint32_t* v = &m.indices[3 * t];
    normals[t] = normalize(cross(vertices[v[1]] - vertices[v[0]], vertices[v[2]] - vertices[v[0]]));
    for (int c = 0; c < 3; ++c) {
      Key a = key(v[c]), b = key(v[(c + 1) % 3]);
      if (b < a) std::swap(a, b);
      edges[{a, b}].push_back(t);
      fans[key(v[c])].push_back(t);
    }
  }
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u01(0, 1);
  LeakCount count;
  std::vector<std::pair<Vec3<T>, Vec3<T>>> rays;
  // A ray through `at` along some d crossing every triangle of `tris` at a clear angle.
  auto fire = [&](const Vec3<double>& at, const std::vector<std::size_t>& tris) {
    for (int attempt = 0; attempt < 64; ++attempt) {
      const Vec3<double> d = random_unit(rng);
      const double s0 = dot(d, normals[tris[0]]);
      bool clear = std::fabs(s0) > 0.1;
      for (std::size_t t : tris) clear = clear && dot(d, normals[t]) * s0 > 0.01;
      if (!clear) continue;
      // The origin rounded to T first, the direction then aimed from it at the point: the ray
      // passes within an ulp of the direction (times reach) of it, whatever the origin's
      // magnitude.
      const Vec3<T> ot = Vec3<T>::from(at - d * reach);
      const Vec3<double> aim = at - Vec3<double>{double(ot.x), double(ot.y), double(ot.z)};
      const Vec3<T> dt = Vec3<T>::from(normalize(aim));
      rays.push_back({ot, dt});
      return;
    }
  };
  for (const auto& [e, tris] : edges) {
    if (tris.size() != 2) continue;
    ++count.edges;
    const Vec3<double> a{std::get<0>(e.first), std::get<1>(e.first), std::get<2>(e.first)};
    const Vec3<double> b{std::get<0>(e.second), std::get<1>(e.second), std::get<2>(e.second)};
    for (int k = 0; k < points_per_edge; ++k) {
      const double w = k == 0 ? 0.5 : u01(rng);
      fire(a + (b - a) * w, tris);
    }
  }
  for (const auto& [v, tris] : fans) fire({std::get<0>(v), std::get<1>(v), std::get<2>(v)}, tris);
  auto leaked = [&](const reference::Hit<T>& h) {
    return h.id < 0 || double(h.t) > reach * (1 + 1e-4);
  };
  count.rays = rays.size();
  for (const auto& [o, d] : rays) count.leaks += leaked(reference::closest_hit(p, o, d));
  for (const int width :
       packet::supported_widths(std::is_same_v<T, float> ? Precision::exact : Precision::dbl)) {
    const packet::KernelTable<T>* k = width > 1 ? kernels_of<T>(width) : nullptr;
    if (!k) continue;
    std::size_t& n = count.packet_leaks[width];
    std::size_t& differ = count.packet_differs[width];
    const std::vector<reference::Hit<T>> hits = packet_hits(p, *k, rays);
    for (std::size_t r = 0; r < rays.size(); ++r) {
      n += leaked(hits[r]);
      const reference::Hit<T> ref = reference::closest_hit(p, rays[r].first, rays[r].second);
      differ += hits[r].id != ref.id || (ref.id >= 0 && std::memcmp(&hits[r].t, &ref.t, sizeof(T)));
    }
  }
  return count;
}

// Every packet width this CPU runs traced the same rays, and none passed through.
void expect_no_packet_leaks(const LeakCount& c, const std::string& what) {
  EXPECT_FALSE(c.packet_leaks.empty()) << what << ": no packet width ran";
  for (const auto& [width, leaks] : c.packet_leaks)
    EXPECT_EQ(leaks, 0u) << what << ", width " << width << ": " << leaks << " of " << c.rays
                         << " rays passed through";
  for (const auto& [width, differ] : c.packet_differs)
    EXPECT_EQ(differ, 0u) << what << ", width " << width << ": " << differ << " of " << c.rays
                          << " hits not the reference's";
}

template <class T>
void expect_watertight(const Shape& mesh, const char* what, std::uint64_t seed) {
  Scene s = empty_scene();
  s.shapes.push_back(mesh);
  const LeakCount c = count_leaks<T>(s, seed, 3);
  EXPECT_GT(c.rays, 2 * c.edges) << what;
  EXPECT_EQ(c.leaks, 0u) << what << ": " << c.leaks << " of " << c.rays << " rays through "
                         << c.edges << " shared edges and the vertices passed through";
  expect_no_packet_leaks(c, what);
}

TEST(Prims, WatertightTessellatedSpheresAndBoxes) {
  LANCER_SKIP_WITHOUT_PACKETS();
  // Far from the origin too: there a float vertex minus the ray's origin rounds, and the same
  // rounding must serve every triangle at that vertex.
  for (const Vec3<double> c : {Vec3<double>{0, 0, -5}, Vec3<double>{1e3, -2e3, 3e3 + 0.1}}) {
    expect_watertight<float>(uv_sphere(c, 1.5, 24, 48), "float sphere", 1);
    expect_watertight<double>(uv_sphere(c, 1.5, 24, 48), "double sphere", 2);
    expect_watertight<float>(grid_box(c - Vec3<double>{1, 2, 0.5}, c + Vec3<double>{1, 0.3, 2}, 6),
                             "float box", 3);
    expect_watertight<double>(grid_box(c - Vec3<double>{1, 2, 0.5}, c + Vec3<double>{1, 0.3, 2}, 6),
                              "double box", 4);
  }
  // Tiny triangles: 2e-4 across, 2 units from the origin (float keeps their vertices apart to
  // a thousandth of their size; at 1e3 its 6e-5 grid would collapse them into slivers, whose
  // T-junctions no test closes).
  expect_watertight<float>(uv_sphere({0.3, 1, -2}, 1e-3, 16, 32), "tiny float sphere", 5);
  expect_watertight<double>(uv_sphere({3e2, 1e3, -2e2}, 1e-3, 16, 32), "tiny double sphere", 6);
}

// lancer generate's tessellated sphere (binary PLY): closed, and watertight where it is traced.
TEST(Prims, WatertightGeneratedSphere) {
  LANCER_SKIP_WITHOUT_PACKETS();
  long long triangles = 0;
  MeshFile f = parse_ply(generate::sphere_ply(20000, &triangles), "g.ply");
  EXPECT_GE(triangles, 20000);
  EXPECT_EQ(f.indices.size(), std::size_t(3 * triangles));
  Shape sh;
  MeshTransform t;
  t.scale = {2, 2, 2};
  t.translate = {0.5, -0.25, -6};
  place_mesh(std::move(f), t, false, "g.ply", sh.mesh);
  EXPECT_EQ(sh.mesh.dropped, 0u);
  Scene s = empty_scene();
  s.shapes.push_back(std::move(sh));
  const LeakCount c = count_leaks<float>(s, 11, 1);
  EXPECT_EQ(c.edges, std::size_t(3 * triangles / 2));  // closed: every edge shared by two
  EXPECT_EQ(c.leaks, 0u) << c.leaks << " of " << c.rays << " rays leaked";
  expect_no_packet_leaks(c, "generated sphere");
}

// The leaves (index, count) under node i, through the wide nodes (kLone false) or the lone
// nodes, sorted; and each slot's box met on the way, keyed by the slot's (child, count). `slots`:
// the slots of node i taken (every later node's all).
template <class T, bool kLone>
void subtree(const PreparedShapes<T>& s, std::int32_t i,
             std::vector<std::pair<std::int32_t, int>>& leaves,
             std::map<std::pair<std::int32_t, int>, std::vector<T>>* boxes,
             std::uint32_t slots = ~0u) {
  const auto& n = [&]() -> const auto& {
    if constexpr (kLone)
      return s.lone[std::size_t(i)];
    else
      return s.wide[std::size_t(i)];
  }
  ();
  for (int k = 0; k < n.arity; ++k) {
    if (!(slots >> k & 1u)) continue;
    if (boxes)
      (*boxes)[{n.child[k], n.count[k]}] = {n.lo_x[k], n.lo_y[k], n.lo_z[k],
                                            n.hi_x[k], n.hi_y[k], n.hi_z[k]};
    if (n.count[k] > 0)
      leaves.push_back({n.child[k], n.count[k]});
    else
      subtree<T, kLone>(s, n.child[k], leaves, boxes);
  }
}

// Whether the box lo/hi (6 values) holds every leaf box of lone node i's subtree.
template <class T>
bool holds(const PreparedShapes<T>& s, const std::vector<T>& box, std::int32_t i,
           const std::map<std::pair<std::int32_t, int>, std::vector<T>>& leaf_boxes) {
  std::vector<std::pair<std::int32_t, int>> under;
  subtree<T, true>(s, i, under, nullptr);
  for (const auto& l : under) {
    const std::vector<T>& b = leaf_boxes.at(l);
    for (int a = 0; a < 3; ++a)
      if (!(box[a] <= b[a] && b[3 + a] <= box[3 + a])) return false;
  }
  return true;
}

// The lone nodes hold the tree from the root, each leaf once; a lane handed over at any wide
// node starts at its entry (lone node and slots) and meets the same leaves as the wide node's
// subtree. Leaves' boxes are the wide nodes' bits, an inner slot's box holds its subtree's,
// nodes are full (kLone slots) unless every slot is a leaf, and unused slots have empty boxes.
template <class T>
void expect_lone_nodes(const Scene& scene) {
  const PreparedScene<T> p = prepare<T>(scene);
  ASSERT_TRUE(p.shapes);
  const PreparedShapes<T>& s = *p.shapes;
  ASSERT_EQ(s.lone_entry.size(), s.wide.size());
  ASSERT_LT(s.lone.size(), s.wide.size());  // fuller nodes: fewer
  std::map<std::pair<std::int32_t, int>, std::vector<T>> wide_boxes, lone_boxes;
  std::vector<std::pair<std::int32_t, int>> all, from_root;
  subtree<T, false>(s, 0, all, &wide_boxes);
  subtree<T, true>(s, 0, from_root, &lone_boxes);
  std::size_t items = 0;
  for (const auto& l : all) items += std::size_t(l.second);
  EXPECT_EQ(items, s.items());
  std::sort(all.begin(), all.end()), std::sort(from_root.begin(), from_root.end());
  ASSERT_EQ(all, from_root);
  for (std::size_t i = 0; i < s.wide.size(); ++i) {
    std::vector<std::pair<std::int32_t, int>> a, b;
    subtree<T, false>(s, std::int32_t(i), a, nullptr);
    const auto e = s.lone_entry[i];
    ASSERT_GE(e.node, 0);
    ASSERT_LT(std::size_t(e.node), s.lone.size());
    subtree<T, true>(s, e.node, b, nullptr, e.slots);
    std::sort(a.begin(), a.end()), std::sort(b.begin(), b.end());
    ASSERT_EQ(a, b) << "wide node " << i;
  }
  for (std::size_t i = 0; i < s.lone.size(); ++i) {
    const auto& n = s.lone[i];
    ASSERT_LE(n.arity, PreparedShapes<T>::kLone);
    bool inner = false;
    for (int k = 0; k < n.arity; ++k) {
      const std::vector<T> box = {n.lo_x[k], n.lo_y[k], n.lo_z[k], n.hi_x[k], n.hi_y[k], n.hi_z[k]};
      if (n.count[k] > 0) {
        ASSERT_EQ(
            std::memcmp(box.data(), wide_boxes.at({n.child[k], n.count[k]}).data(), sizeof(T) * 6),
            0)
            << "lone node " << i;
      } else {
        inner = true;
        ASSERT_TRUE(holds(s, box, n.child[k], wide_boxes)) << "lone node " << i;
      }
    }
    if (inner) {
      EXPECT_EQ(n.arity, PreparedShapes<T>::kLone) << "lone node " << i;
    }
    for (int k = n.arity; k < PreparedShapes<T>::kLone; ++k)
      EXPECT_TRUE(n.lo_x[k] > n.hi_x[k] && n.lo_y[k] > n.hi_y[k] && n.lo_z[k] > n.hi_z[k]);
  }
  // The leaves: the binary tree's, in leaf order, each named once; each item's reference and
  // number as prim's, a triangle's vertices the bits of vx, vy, vz, and the rows an item leaves
  // free the leaf's first triangle's (zeros where it has none).
  std::vector<std::pair<std::uint32_t, std::uint32_t>> tree;  // (first, count)
  for (const auto& b : s.nodes)
    if (b.count > 0) tree.push_back({b.first, b.count});
  std::sort(tree.begin(), tree.end());
  ASSERT_EQ(s.leaves.size(), tree.size());
  for (std::size_t i = 0; i < all.size(); ++i) ASSERT_EQ(all[i].first, std::int32_t(i));
  for (std::size_t i = 0; i < tree.size(); ++i) {
    const auto& l = s.leaves[i];
    ASSERT_EQ(l.count, tree[i].second);
    for (unsigned k = 0; k < l.count; ++k) {
      const std::uint32_t item = s.order[tree[i].first + k];
      ASSERT_LT(item, s.prim.size());  // no spheres in these scenes
      EXPECT_EQ(l.prim[k], std::int32_t(item));
      EXPECT_EQ(l.ref[k], s.prim[item]);
      EXPECT_EQ((l.tri >> k & 1u) != 0, s.prim[item] >= 0);
      if (s.prim[item] < 0) continue;
      for (int c = 0; c < 3; ++c) {
        const std::uint32_t v = s.tri[3 * std::size_t(s.prim[item]) + std::size_t(c)];
        const T want[3] = {s.vx[v], s.vy[v], s.vz[v]};
        for (int q = 0; q < 3; ++q)
          ASSERT_EQ(std::memcmp(&l.v[3 * c + q][k], &want[q], sizeof(T)), 0) << "leaf " << i;
      }
    }
    const int from = l.tri ? __builtin_ctz(l.tri) : -1;
    for (unsigned k = 0; k < unsigned(PreparedShapes<T>::kLeafItems); ++k) {
      if (l.tri >> k & 1u) continue;
      for (int q = 0; q < 9; ++q) {
        const T want = from < 0 ? T(0) : l.v[q][unsigned(from)];
        ASSERT_EQ(std::memcmp(&l.v[q][k], &want, sizeof(T)), 0) << "leaf " << i << " lane " << k;
      }
    }
  }
}

TEST(Prims, LoneNodesHoldTheTreeAndEveryWideNodesSubtree) {
  MeshFile f = parse_ply(generate::sphere_ply(3000), "g.ply");
  Shape sh;
  place_mesh(std::move(f), MeshTransform{}, false, "g.ply", sh.mesh);
  Scene s = empty_scene();
  s.shapes.push_back(std::move(sh));
  for (int k = 0; k < 12; ++k) {
    Shape cyl;
    cyl.kind = Shape::Kind::cylinder;
    cyl.cylinder.base = {0.2 * k - 1, -1, -2}, cyl.cylinder.top = {0.2 * k - 1, 1, -2.5};
    cyl.cylinder.radius = 0.05;
    s.shapes.push_back(cyl);
  }
  expect_lone_nodes<float>(s);
  expect_lone_nodes<double>(s);
}

// The Stanford bunny of Debian's glmark2-data (a triangle soup: its triangles share edges by
// coordinates only), at the edges shared by exactly two triangles.
TEST(Prims, WatertightStanfordBunny) {
  LANCER_SKIP_WITHOUT_PACKETS();
  const std::string path = "/usr/share/glmark2/models/bunny.obj";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " missing (glmark2-data)";
  MeshFile f = read_mesh_file(path, path);
  Shape sh;
  MeshTransform t;
  t.translate = {0, 0, -4};
  t.rotate = {10, 20, 30};
  place_mesh(std::move(f), t, false, path, sh.mesh);
  EXPECT_GT(sh.mesh.triangles(), 60000u);
  Scene s = empty_scene();
  s.shapes.push_back(std::move(sh));
  const LeakCount c = count_leaks<float>(s, 7, 1);
  EXPECT_GT(c.edges, 50000u);
  EXPECT_EQ(c.leaks, 0u) << c.leaks << " of " << c.rays << " rays leaked";
  expect_no_packet_leaks(c, "bunny");
}

// The nearest hit beyond eps of a ray on a capped cylinder, computed independently in long
// double in the cylinder's own frame (axis along z): the textbook quadratic and the two planes.
// `margin` gets how near the hit lies to a boundary the two computations may see differently
// (a rim, an end of the side, a grazing ray), relative.
long double oracle_cylinder(const Cylinder& c, const Vec3<double>& o, const Vec3<double>& d,
                            double eps, double& margin) {
  using L = long double;
  const Vec3<double> axis = normalize(c.top - c.base);
  const Vec3<double> e1 = normalize(
      cross(axis, std::fabs(axis.x) < 0.6 ? Vec3<double>{1, 0, 0} : Vec3<double>{0, 1, 0}));
  const Vec3<double> e2 = cross(axis, e1);
  auto local = [&](const Vec3<double>& v, L out[3]) {
    const Vec3<double> b[3] = {e1, e2, axis};
    for (int k = 0; k < 3; ++k) out[k] = L(v.x) * b[k].x + L(v.y) * b[k].y + L(v.z) * b[k].z;
  };
  L ol[3], dl[3], al[3];
  local(o, ol), local(d, dl), local(c.base, al);
  for (int k = 0; k < 3; ++k) ol[k] -= al[k];
  const L h = std::sqrt(L(c.top.x - c.base.x) * (c.top.x - c.base.x) +
                        L(c.top.y - c.base.y) * (c.top.y - c.base.y) +
                        L(c.top.z - c.base.z) * (c.top.z - c.base.z));
  const L r = c.radius;
  L best = INFINITY;
  margin = 1;
  const L qa = dl[0] * dl[0] + dl[1] * dl[1];
  const L qb = ol[0] * dl[0] + ol[1] * dl[1];
  const L qc = ol[0] * ol[0] + ol[1] * ol[1] - r * r;
  const L disc = qb * qb - qa * qc;
  if (qa > 0 && disc >= 0) {
    margin = std::min<double>(margin, double(std::sqrt(disc) / (std::sqrt(qa) * r)));
    for (const L t : {(-qb - std::sqrt(disc)) / qa, (-qb + std::sqrt(disc)) / qa}) {
      const L z = ol[2] + t * dl[2];
      if (t > eps && z >= 0 && z <= h && t < best) {
        best = t;
        margin = std::min<double>(margin, double(std::min(z, h - z) / h));
      }
    }
  }
  if (dl[2] != 0)
    for (const L zc : {L(0), h}) {
      const L t = (zc - ol[2]) / dl[2];
      const L x = ol[0] + t * dl[0], y = ol[1] + t * dl[1];
      const L rad = std::sqrt(x * x + y * y);
      if (t > eps && rad <= r && t < best) {
        best = t;
        margin = std::min<double>(margin, double((r - rad) / r));
      }
    }
  return best;
}

// Seeded property test: random cylinders and rays over magnitudes from 1e-2 to 1e3, the
// reference (double) against the long double oracle, away from boundaries.
TEST(Prims, CylindersAgreeWithAnIndependentComputation) {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u(-1, 1);
  int compared = 0, hits = 0, disagree = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const double scale = log_uniform(rng, 1e-2, 1e3);
    Cylinder c;
    c.base = Vec3<double>{u(rng), u(rng), u(rng) - 3} * scale;
    c.top = c.base + random_unit(rng) * (scale * log_uniform(rng, 0.1, 10));
    c.radius = scale * log_uniform(rng, 0.05, 2);
    Scene s = empty_scene();
    Shape sh;
    sh.kind = Shape::Kind::cylinder;
    sh.cylinder = c;
    s.shapes.push_back(sh);
    s.epsilon = 0;
    const PreparedScene<double> p = prepare<double>(s);
    const Vec3<double> target = c.base + (c.top - c.base) * (u(rng) * 0.8 + 0.5) +
                                random_unit(rng) * (c.radius * 1.3 * std::fabs(u(rng)));
    const Vec3<double> o = target + random_unit(rng) * (scale * log_uniform(rng, 1, 100));
    const Vec3<double> d = normalize(target - o);
    double margin;
    const long double want = oracle_cylinder(c, o, d, 0, margin);
    if (margin < 1e-6) continue;
    ++compared;
    const reference::Hit<double> h = reference::closest_hit(p, o, d);
    const bool hit = std::isfinite(double(want));
    hits += hit;
    if (hit != (h.id >= 0) ||
        (hit && std::fabs(double(h.t - want)) > 1e-9 * (double(want) + scale))) {
      ++disagree;
      ADD_FAILURE() << "trial " << trial << ": oracle " << double(want) << ", reference "
                    << (h.id >= 0 ? h.t : -1.0);
      if (disagree > 5) break;
    }
  }
  EXPECT_GT(compared, 3000);
  EXPECT_GT(hits, compared / 4);
  EXPECT_LT(hits, compared);
}

// The ray along the axis hits a cap with normal +-axis; a ray across the side, the side with the
// radial normal; an open cylinder (caps false) is missed along its axis, hit inside its side.
TEST(Prims, CylinderPartsAndNormals) {
  Scene s = empty_scene();
  Shape sh;
  sh.kind = Shape::Kind::cylinder;
  sh.cylinder.base = {0, 0, -5};
  sh.cylinder.top = {0, 0, -3};
  sh.cylinder.radius = 0.5;
  s.shapes.push_back(sh);
  sh.cylinder.base = {3, 0, -5};
  sh.cylinder.top = {3, 0, -3};
  sh.cylinder.caps = false;
  s.shapes.push_back(sh);
  const PreparedScene<double> p = prepare<double>(s);
  const PreparedShapes<double>& ps = *p.shapes;
  auto probe = [&](Vec3<double> o, Vec3<double> d, Vec3<double>& n) {
    const ShapeHit<double> h = shapes_closest(ps, o, d, 1e-9, double(INFINITY));
    if (h.object < 0) return h;
    Vec3<double> shading;
    shapes_normals(ps, h, o, d, along(o, d, h.t), n, shading);
    return h;
  };
  Vec3<double> n;
  ShapeHit<double> h = probe({0.1, 0.2, 0}, {0, 0, -1}, n);
  EXPECT_EQ(h.object, 0);
  EXPECT_DOUBLE_EQ(h.t, 3);
  EXPECT_EQ(n.z, 1);  // the top cap's +axis
  h = probe({0.1, 0.2, -10}, {0, 0, 1}, n);
  EXPECT_DOUBLE_EQ(h.t, 5);
  EXPECT_EQ(n.z, -1);  // the base cap's -axis
  h = probe({-2, 0, -4}, {1, 0, 0}, n);
  EXPECT_DOUBLE_EQ(h.t, 1.5);
  EXPECT_NEAR(n.x, -1, 1e-15);
  h = probe({3.1, 0, 0}, {0, 0, -1}, n);
  EXPECT_EQ(h.object, -1);  // open: straight through along the axis
  h = probe({3, 0, -4}, {1, 0, 0}, n);
  EXPECT_EQ(h.object, 1);  // from inside the open tube, its side
  EXPECT_DOUBLE_EQ(h.t, 0.5);
}

// Ties: identical triangles as separate objects go to the first in the file; within a mesh, a
// repeated triangle to its first copy.
TEST(Prims, TiesGoToTheFirstObjectAndTriangle) {
  Scene s = empty_scene();
  const std::vector<Vec3<double>> v{{-1, -1, -3}, {1, -1, -3}, {0, 1, -3}};
  s.shapes.push_back(mesh_shape(v, {0, 1, 2, 2, 1, 0}));
  s.shapes.push_back(mesh_shape(v, {0, 1, 2}));
  Shape cyl;
  cyl.kind = Shape::Kind::cylinder;
  cyl.cylinder.base = {0, 0, -5};
  cyl.cylinder.top = {0, 0, -3};  // its top cap lies in the triangles' plane
  cyl.cylinder.radius = 0.5;
  s.shapes.insert(s.shapes.begin(), cyl);
  const PreparedScene<float> p = prepare<float>(s);
  const reference::Hit<float> h = reference::closest_hit(p, Vec3<float>{0.1f, 0, 0}, {0, 0, -1});
  EXPECT_EQ(h.id, 0);  // the cylinder, first in the file
  s.shapes.erase(s.shapes.begin());
  const PreparedScene<float> q = prepare<float>(s);
  const ShapeHit<float> sh = shapes_closest(*q.shapes, {0.1f, 0, 0}, {0, 0, -1}, 1e-4f, INFINITY);
  EXPECT_EQ(sh.object, 0);
  EXPECT_EQ(sh.prim, 0);
  EXPECT_EQ(sh.t, 3.0f);
}

// Smooth normals: the blend of the file's normals, transformed as normals (scale [2, 1, 1]
// and a rotation), by the hit's barycentric weights, against the same computed here in double.
TEST(Prims, SmoothNormalsBlendTheTransformedVertexNormals) {
  MeshFile f;
  f.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  f.normals = {{0, 0, 1}, {1, 0, 1}, {0, 2, 1}};
  f.indices = {0, 1, 2};
  f.normal_indices = {0, 1, 2};
  MeshTransform t;
  t.scale = {2, 1, 1};
  t.rotate = {0, 90, 0};  // (x, y, z) -> (z, y, -x)
  t.translate = {0, 0, -4};
  Shape sh;
  place_mesh(MeshFile(f), t, true, "n.ply", sh.mesh);
  Scene s = empty_scene();
  s.shapes.push_back(sh);
  const PreparedScene<double> p = prepare<double>(s);
  // Vertices now (0,0,-4), (0,0,-6), (0,1,-4): the plane x = 0. A ray along -x... from +x.
  const Vec3<double> bary{0.2, 0.3, 0.5};
  const Vec3<double> at =
      sh.mesh.vertices[0] * bary.x + sh.mesh.vertices[1] * bary.y + sh.mesh.vertices[2] * bary.z;
  const Vec3<double> o = at + Vec3<double>{5, 0.1, 0.2}, d = normalize(at - o);
  const ShapeHit<double> h = shapes_closest(*p.shapes, o, d, 1e-9, double(INFINITY));
  ASSERT_EQ(h.object, 0);
  Vec3<double> geometric, shading;
  shapes_normals(*p.shapes, h, o, d, along(o, d, h.t), geometric, shading);
  // Independently: n / scale, rotated by Ry(90): (x, y, z) -> (z, y, -x), normalised, blended.
  auto n = [&](Vec3<double> m) {
    m = {m.x / 2, m.y, m.z};
    return normalize(Vec3<double>{m.z, m.y, -m.x});
  };
  const Vec3<double> want =
      normalize(n(f.normals[0]) * bary.x + n(f.normals[1]) * bary.y + n(f.normals[2]) * bary.z);
  EXPECT_NEAR(shading.x, want.x, 1e-9);
  EXPECT_NEAR(shading.y, want.y, 1e-9);
  EXPECT_NEAR(shading.z, want.z, 1e-9);
  EXPECT_NEAR(std::fabs(geometric.x), 1, 1e-15);
}

// Without normals in the file, a vertex's normal is the area-weighted sum of its triangles':
// at a vertex shared by a big and a small triangle folded at a right angle, the blend leans to
// the big one.
TEST(Prims, SmoothNormalsWithoutFileNormalsAreAreaWeighted) {
  MeshFile f;
  f.positions = {{0, 0, 0}, {0, 1, 0}, {3, 0, 0}, {0, 0, 1}};
  f.indices = {0, 2, 1, 0, 1, 3};  // in z = 0 (area 1.5, normal +z) and x = 0 (area 0.5, +x)
  Shape sh;
  place_mesh(MeshFile(f), MeshTransform{}, true, "a.obj", sh.mesh);
  const Vec3<double> n0 = sh.mesh.normals[sh.mesh.normal_indices[0]];
  const Vec3<double> c1 = cross(f.positions[2] - f.positions[0], f.positions[1] - f.positions[0]);
  const Vec3<double> c2 = cross(f.positions[1] - f.positions[0], f.positions[3] - f.positions[0]);
  const Vec3<double> want = normalize(c1 + c2);
  EXPECT_DOUBLE_EQ(n0.x, want.x);
  EXPECT_DOUBLE_EQ(n0.y, want.y);
  EXPECT_DOUBLE_EQ(n0.z, want.z);
  EXPECT_GT(std::fabs(want.z), 2.9 * std::fabs(want.x));
}

// A closed glass mesh between a point and its light counts once: the light arrives times
// transmit, not transmit squared, though the shadow ray crosses two of its triangles.
TEST(Prims, ShadowRaysCountAMeshOnce) {
  auto render_pixel = [](bool cube, double intensity) {
    Scene s = empty_scene();
    s.camera.position = {3, 1, 0};
    s.camera.direction = {-3, -1, 0};
    s.camera.distance = 1;
    s.camera.xmin = s.camera.ymin = -1e-3;
    s.camera.xmax = s.camera.ymax = 1e-3;
    Light l;
    l.position = {0, 10, 0};
    l.intensity = {intensity, intensity, intensity};
    s.lights.push_back(l);
    Plane ground;
    ground.point = {0, 0, 0};
    ground.normal = {0, 1, 0};
    s.planes.push_back(ground);
    if (cube) {
      Material glass;
      glass.kd = 0;
      glass.transmit = 0.5;
      s.materials.push_back(glass);
      Shape box = grid_box({-0.5, 2.5, -0.5}, {0.5, 3.5, 0.5}, 2);
      box.mesh.material = 1;
      s.shapes.push_back(box);
    }
    RenderOptions opt;
    opt.width = 1;
    opt.threads = 1;
    const Image im = render(s, opt).image;
    return im.pixel(0, 0)[0];
  };
  const float through = render_pixel(true, 1.0), half = render_pixel(false, 0.5);
  EXPECT_GT(half, 0.4f);
  EXPECT_EQ(through, half);
}

}  // namespace
}  // namespace lancer
