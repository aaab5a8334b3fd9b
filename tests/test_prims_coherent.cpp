// Coherent packets of triangles (camera tiles, shadow rays towards a light), and incoherent ones
// with zero direction components, against the reference: closest hits bit for bit and segments
// blocked exactly before the hit, at every packet width, through the per-lane walk and the
// frustum walk.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <tuple>
#include <vector>

#include "lancer/packet/api.hpp"
#include "lancer/prepared.hpp"
#include "lancer/reference.hpp"
#include "lancer/scene.hpp"
#include "support/prims_meshes.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

using namespace prims_test;

// The packets' closest hits of `rays` (prepared frame) are the reference's at every width, and
// their segments are blocked exactly before the hit and not at it. Returns how many rays hit.
template <class T>
std::size_t expect_packets_match(const PreparedScene<T>& p,
                                 const std::vector<std::pair<Vec3<T>, Vec3<T>>>& rays,
                                 const char* what) {
  std::vector<reference::Hit<T>> ref(rays.size());
  std::size_t hit = 0;
  for (std::size_t r = 0; r < rays.size(); ++r) {
    ref[r] = reference::closest_hit(p, rays[r].first, rays[r].second);
    hit += ref[r].id >= 0;
  }
  std::size_t checked = 0;
  for (const int width :
       packet::supported_widths(std::is_same_v<T, float> ? Precision::exact : Precision::dbl)) {
    const packet::KernelTable<T>* k = width > 1 ? kernels_of<T>(width) : nullptr;
    if (!k) continue;
    const std::vector<reference::Hit<T>> hits = packet_hits(p, *k, rays);
    std::size_t differ = 0;
    for (std::size_t r = 0; r < rays.size(); ++r)
      differ += hits[r].id != ref[r].id ||
                (ref[r].id >= 0 && std::memcmp(&hits[r].t, &ref[r].t, sizeof(T)));
    EXPECT_EQ(differ, 0u) << what << ", width " << width << ": " << differ << " of " << rays.size()
                          << " hits not the reference's";
    // Segments ending at the hit (nothing before it) and just past it (the hit blocks).
    for (const bool past : {false, true}) {
      const std::vector<char> blocked = packet_blocked(p, *k, rays, [&](std::size_t r) {
        const T t = ref[r].id >= 0 ? ref[r].t : std::numeric_limits<T>::max();
        return past ? std::nextafter(t, std::numeric_limits<T>::infinity()) : t;
      });
      std::size_t wrong = 0;
      for (std::size_t r = 0; r < rays.size(); ++r)
        wrong += bool(blocked[r]) != (past && ref[r].id >= 0);
      EXPECT_EQ(wrong, 0u) << what << ", width " << width << ", segments " << (past ? "past" : "to")
                           << " the hit: " << wrong << " of " << rays.size() << " wrong";
    }
    ++checked;
  }
  EXPECT_GT(checked, 0u) << what << ": no packet width ran";
  return hit;
}

// Coherent packets, as a camera's tiles make them: directions of one sign per axis within a
// small cone, aimed at a mesh's vertices and edge points, where the rays pass exactly through
// the corners and faces of the hierarchy's boxes; from one origin, or (spread > 0) from origins
// scattered about it by log-uniform distances up to `spread`, as shadow rays from a tile's hit
// points are. Their closest hits are the reference's at every width, and their segments are
// blocked exactly before the reference's hit and not at it: the packet-wide culling of the
// shapes' walk (per lane, or by the packet's frustum) never turns away a box some lane would
// meet.
template <class T>
void expect_coherent_packets_agree(const Shape& mesh, const Vec3<double>& eye, const char* what,
                                   double spread = 0, std::size_t stride = 1) {
  Scene s = empty_scene();
  s.shapes.push_back(mesh);
  const PreparedScene<T> p = prepare<T>(s);
  const Mesh& m = s.shapes[0].mesh;
  std::mt19937_64 rng(7);
  std::vector<std::tuple<Vec3<double>, Vec3<T>, Vec3<T>>> keyed;  // (cell, origin, direction)
  auto aim = [&](const Vec3<double>& at) {
    const Vec3<T> o = Vec3<T>::from(
        spread > 0 ? eye + random_unit(rng) * log_uniform(rng, spread * 1e-6, spread) : eye);
    const Vec3<double> d = normalize(at - Vec3<double>{double(o.x), double(o.y), double(o.z)});
    // Cells of the image plane 1/64 of a unit wide: a packet's rays lie in one or two.
    keyed.push_back(
        {{std::floor(d.x / -d.z * 64), std::floor(d.y / -d.z * 64), 0}, o, Vec3<T>::from(d)});
  };
  for (std::size_t t = 0; t < m.triangles(); t += stride) {
    const std::uint32_t* v = &m.indices[3 * t];
    for (int c = 0; c < 3; ++c) {
      const Vec3<double> a = m.vertices[v[c]], b = m.vertices[v[(c + 1) % 3]];
      aim(a), aim((a + b) * 0.5);
    }
  }
  std::stable_sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) {
    return std::tie(std::get<0>(a).y, std::get<0>(a).x) <
           std::tie(std::get<0>(b).y, std::get<0>(b).x);
  });
  std::vector<std::pair<Vec3<T>, Vec3<T>>> rays;
  for (const auto& [cell, o, d] : keyed) rays.push_back({o, d});
  EXPECT_GT(expect_packets_match(p, rays, what), rays.size() / 3) << what;
}

TEST(Prims, CoherentPacketsGetTheReferencesHits) {
  for (const Vec3<double> c : {Vec3<double>{0.5, -0.25, -6}, Vec3<double>{1e3, -2e3, -3e3}}) {
    const Vec3<double> eye = c + Vec3<double>{-0.3, 0.2, 6};
    expect_coherent_packets_agree<float>(uv_sphere(c, 1.5, 48, 96), eye, "float sphere");
    expect_coherent_packets_agree<double>(uv_sphere(c, 1.5, 48, 96), eye, "double sphere");
    expect_coherent_packets_agree<float>(
        grid_box(c - Vec3<double>{1, 2, 0.5}, c + Vec3<double>{1, 0.3, 2}, 12), eye, "float box");
  }
}

// Also on meshes large enough for the packets' frustum walk (PreparedShapes of 32768
// primitives or more; packet/prim/shapes.hpp), rays at every 16th triangle's corners.
TEST(Prims, CoherentPacketsFromScatteredOriginsGetTheReferencesHits) {
  for (const Vec3<double> c : {Vec3<double>{0.5, -0.25, -6}, Vec3<double>{1e3, -2e3, -3e3}}) {
    const Vec3<double> eye = c + Vec3<double>{-0.3, 0.2, 6};
    const Shape sphere = uv_sphere(c, 1.5, 128, 256);
    const Shape box = grid_box(c - Vec3<double>{1, 2, 0.5}, c + Vec3<double>{1, 0.3, 2}, 64);
    ASSERT_GE(sphere.mesh.triangles(), 32768u);
    ASSERT_GE(box.mesh.triangles(), 32768u);
    for (const double spread : {0.0, 1e-3, 0.5}) {
      expect_coherent_packets_agree<float>(sphere, eye, "float sphere", spread, 16);
      expect_coherent_packets_agree<double>(sphere, eye, "double sphere", spread, 16);
      expect_coherent_packets_agree<float>(box, eye, "float box", spread, 16);
    }
  }
}

// Incoherent packets (random directions from scattered origins, as ambient occlusion and
// diffuse bounces make them) in which every third ray has a zero direction component, or two
// (the axis turning from ray to ray), beside packets with none: the shapes' walk tests boxes by
// the generic form where a live lane has a zero component (its origin must then lie within
// that slab) and by the no_zero form where none has (shapes_walk.hpp's BoxTest). Over a box of
// axis-aligned faces, rays with zero components run within its faces' planes and its boxes'
// sides. Closest hits and blocked segments are the reference's at every width.
template <class T>
void expect_incoherent_packets_agree(const Shape& mesh, const Vec3<double>& c, double reach,
                                     const char* what) {
  Scene s = empty_scene();
  s.shapes.push_back(mesh);
  const PreparedScene<T> p = prepare<T>(s);
  std::mt19937_64 rng(11);
  std::vector<std::pair<Vec3<T>, Vec3<T>>> rays;
  for (int r = 0; r < 4096; ++r) {
    // Packets of 16 rays from near one point; the first packet of each four has no zero.
    const bool zeros = (r / 16) % 4 != 0;
    const Vec3<double> at = c + random_unit(rng) * log_uniform(rng, reach * 1e-3, reach);
    Vec3<double> d = random_unit(rng);
    if (zeros && r % 3 == 0) {
      double* comp[3] = {&d.x, &d.y, &d.z};
      *comp[r % 9 / 3] = 0;
      if (r % 27 == 0) *comp[(r % 9 / 3 + 1) % 3] = 0;
      d = normalize(d);
    }
    // The box's own planes: a ray with a zero component starting on one of them.
    const Vec3<double> o = r % 5 == 0 ? Vec3<double>{at.x, at.y, std::round(at.z)} : at;
    rays.push_back({Vec3<T>::from(o), Vec3<T>::from(d)});
  }
  const std::size_t hit = expect_packets_match(p, rays, what);
  EXPECT_GT(hit, rays.size() / 4) << what;
  EXPECT_LT(hit, rays.size()) << what;
}

TEST(Prims, IncoherentPacketsWithZeroDirectionComponentsGetTheReferencesHits) {
  const Vec3<double> c{0.5, -0.25, -6};
  const Shape box = grid_box(c - Vec3<double>{2, 2, 2}, c + Vec3<double>{2, 2, 2}, 8);
  expect_incoherent_packets_agree<float>(box, c, 4, "float box");
  expect_incoherent_packets_agree<double>(box, c, 4, "double box");
  expect_incoherent_packets_agree<float>(uv_sphere(c, 1.5, 32, 64), c, 3, "float sphere");
}

}  // namespace
}  // namespace lancer
