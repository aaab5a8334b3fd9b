// The library API's one-ray queries on the one-ray kernels (packet/one_ray.hpp) against the
// reference (Options::width 1): every answer's bits, on seeded incoherent rays over the shipped
// scenes and generated clouds, in exact float and double; and the edges (origins far beyond
// the hierarchy's origin limit, zero direction components, tangent rays).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "api/api_util.hpp"
#include "lancer/bvh.hpp"
#include "lancer/generate.hpp"
#include "lancer/lancer.hpp"
#include "lancer/packet/api.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

using testing::with;
constexpr float kInf = std::numeric_limits<float>::infinity();

struct Ray {
  float o[3], d[3];
  float tnear = 0, tfar = kInf;
};

struct Answer {
  api::Hit1 hit;
  int blocked = 0;
};

template <class P>
void set_lane(P& r, int k, const Ray& ray) {
  r.org_x[k] = ray.o[0], r.org_y[k] = ray.o[1], r.org_z[k] = ray.o[2];
  r.dir_x[k] = ray.d[0], r.dir_y[k] = ray.d[1], r.dir_z[k] = ray.d[2];
  r.tnear[k] = ray.tnear, r.tfar[k] = ray.tfar, r.mask[k] = api::kAllObjects;
}

Answer one(const api::Scene& s, const Ray& ray) {
  api::Ray1 r;
  set_lane(r, 0, ray);
  Answer a;
  s.intersect(nullptr, r, a.hit);
  s.occluded(nullptr, r, &a.blocked);
  return a;
}

bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// The API's whole answer, bit for bit.
::testing::AssertionResult same(const Answer& a, const Answer& b) {
  const api::Hit1 &x = a.hit, &y = b.hit;
  if (x.id[0] != y.id[0] || x.prim_id[0] != y.prim_id[0] || !same_bits(x.t[0], y.t[0]) ||
      !same_bits(x.u[0], y.u[0]) || !same_bits(x.v[0], y.v[0]) ||
      !same_bits(x.ng_x[0], y.ng_x[0]) || !same_bits(x.ng_y[0], y.ng_y[0]) ||
      !same_bits(x.ng_z[0], y.ng_z[0]) || a.blocked != b.blocked)
    return ::testing::AssertionFailure()
           << "id " << x.id[0] << " vs " << y.id[0] << ", t " << x.t[0] << " vs " << y.t[0]
           << ", n (" << x.ng_x[0] << ", " << x.ng_y[0] << ", " << x.ng_z[0] << ") vs ("
           << y.ng_x[0] << ", " << y.ng_y[0] << ", " << y.ng_z[0] << "), occluded " << a.blocked
           << " vs " << b.blocked;
  return ::testing::AssertionSuccess();
}

void unit(float* d, std::mt19937_64& g) {
  std::normal_distribution<double> n;
  double v[3], l;
  do {
    for (double& x : v) x = n(g);
    // A zero component now and then: axis-parallel slabs.
    for (double& x : v)
      if (std::uniform_int_distribution<int>(0, 7)(g) == 0) x = 0;
    l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  } while (l < 1e-3);
  for (int a = 0; a < 3; ++a) d[a] = float(v[a] / l);
}

// Incoherent rays: origins in the spheres' box or anywhere at log-uniform magnitudes (1e-3 to
// 1e21: beyond the origin limit and the far limit too), random directions, tnear and tfar
// varied (0, infinity, the hit's own t); and rays leaving the surface points they hit.
std::vector<Ray> rays_for(const api::Scene& ref, std::size_t n, std::uint64_t seed) {
  const Scene& s = ref.description();
  double lo[3] = {-1, -1, -1}, hi[3] = {1, 1, 1};
  for (std::size_t i = 0; i < s.spheres.size(); ++i) {
    const Sphere& sp = s.spheres[i];
    const double c[3] = {sp.center.x, sp.center.y, sp.center.z};
    for (int a = 0; a < 3; ++a) {
      if (i == 0) lo[a] = hi[a] = c[a];
      lo[a] = std::min(lo[a], c[a] - sp.radius), hi[a] = std::max(hi[a], c[a] + sp.radius);
    }
  }
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Ray> out;
  while (out.size() < n) {
    Ray r;
    const int kind = int(u(g) * 4);
    for (int a = 0; a < 3; ++a)
      r.o[a] = kind < 2 ? float(lo[a] + (hi[a] - lo[a]) * u(g))
                        : float((u(g) < 0.5 ? -1 : 1) * std::pow(10.0, -3 + 24 * u(g)));
    unit(r.d, g);
    const int t = int(u(g) * 8);
    if (t == 0) r.tfar = 0;
    if (t == 1) r.tfar = float(std::pow(10.0, -2 + 5 * u(g)));
    if (t == 2) r.tnear = float(std::pow(10.0, -4 + 5 * u(g)));
    Answer a = one(ref, r);
    out.push_back(r);
    if (a.hit.id[0] < 0) continue;
    // The same ray ending exactly at its hit (not counted: t < tfar), and starting there.
    Ray end = r;
    end.tfar = a.hit.t[0];
    out.push_back(end);
    Ray start = r;
    start.tnear = a.hit.t[0];
    out.push_back(start);
    // From the hit point, a new direction (the scene's epsilon keeps the surface out or not).
    Ray from;
    for (int k = 0; k < 3; ++k) from.o[k] = r.o[k] + a.hit.t[0] * r.d[k];
    unit(from.d, g);
    out.push_back(from);
  }
  return out;
}

// Every ray's answer from the one-ray kernels and from the reference, and the same rays as a
// packet's lanes with their own tnear (those go on alone too).
void compare(const Scene& desc, Precision p, std::size_t n, std::uint64_t seed,
             const std::string& name) {
  const api::Scene fast = api::Scene::from_description(desc, with(p));
  const api::Scene ref = api::Scene::from_description(desc, with(p, 1));
  ASSERT_EQ(ref.info().one_ray, "scalar");
  SCOPED_TRACE(name + " " + to_string(p) + " on " + fast.info().one_ray);
  const std::vector<Ray> rays = rays_for(ref, n, seed);
  int differ = 0;
  std::size_t hits = 0, blocked = 0;
  for (std::size_t i = 0; i < rays.size() && differ < 5; ++i) {
    const Answer b = one(ref, rays[i]);
    const ::testing::AssertionResult r = same(one(fast, rays[i]), b);
    if (!r) ++differ;
    EXPECT_TRUE(r) << "ray " << i;
    hits += b.hit.id[0] >= 0, blocked += b.blocked != 0;
  }
  // Rays that find something and rays that do not, both ways.
  EXPECT_GT(hits, rays.size() / 20);
  EXPECT_LT(hits, rays.size());
  EXPECT_GT(blocked, rays.size() / 20);
  EXPECT_EQ(blocked, hits);  // the API: blocked exactly where a hit lies before tfar
  // Packets of 8 with tnear beyond epsilon in every lane: each lane alone.
  for (std::size_t i = 0; i + 8 <= rays.size() && differ < 5; i += 64) {
    api::Ray8 r;
    for (int k = 0; k < 8; ++k) {
      Ray x = rays[i + k];
      x.tnear = std::max(x.tnear, 1e-2f);
      set_lane(r, k, x);
    }
    api::Hit8 a, b;
    int oa[8], ob[8];
    fast.intersect(nullptr, r, a), ref.intersect(nullptr, r, b);
    fast.occluded(nullptr, r, oa), ref.occluded(nullptr, r, ob);
    for (int k = 0; k < 8; ++k) {
      EXPECT_EQ(a.id[k], b.id[k]) << "packet at ray " << i << " lane " << k;
      EXPECT_TRUE(same_bits(a.t[k], b.t[k]) && same_bits(a.ng_x[k], b.ng_x[k]) &&
                  same_bits(a.ng_y[k], b.ng_y[k]) && same_bits(a.ng_z[k], b.ng_z[k]));
      EXPECT_EQ(oa[k], ob[k]);
      differ += a.id[k] != b.id[k];
    }
  }
}

bool has_shapes(const Scene& s) { return !s.shapes.empty(); }

TEST(ApiOneRay, ShippedScenesGiveTheReferencesBits) {
  for (const std::string& path : testing::shipped_scenes()) {
    const Scene s = load_scene(path);
    for (Precision p : {Precision::exact, Precision::dbl}) {
      compare(s, p, 3000, 11, path);
      const api::Scene fast = api::Scene::from_description(s, with(p));
      // The one-ray kernels wherever the CPU runs AVX2, whatever the scene holds; without
      // them (SSE4.2 alone), a scene with shapes answers on the narrowest packet kernel.
      const std::string& one = fast.info().one_ray;
      if (fast.info().width == 1) {
        EXPECT_EQ(one, "scalar");
      } else if (fast.info().width >= 8 && p == Precision::exact) {
        EXPECT_TRUE(one == "avx2" || one == "avx512f") << one;
      } else if (has_shapes(s) && fast.info().width == 4) {
        EXPECT_TRUE(one.size() > 7 && one.compare(one.size() - 7, 7, " packet") == 0) << one;
      }
    }
  }
}

Scene cloud(long long n, std::uint64_t seed) {
  generate::Options g;
  g.spheres = n;
  g.seed = seed;
  return parse_scene(generate::scene_json(g), "cloud");
}

TEST(ApiOneRay, GeneratedCloudsGiveTheReferencesBits) {
  for (long long n : {20LL, 1024LL, 65536LL}) {
    const Scene s = cloud(n, 7 + std::uint64_t(n));
    for (Precision p : {Precision::exact, Precision::dbl})
      compare(s, p, n > 20000 ? 6000 : 12000, std::uint64_t(n), "cloud " + std::to_string(n));
  }
}

// Spheres, cylinders among them, a sphere mesh in their midst and the ground plane: the shapes'
// one-ray walk (packet/prim/shapes_lone.hpp) beside the spheres' and the planes', every field
// of the answer (the primitive, u, v) from the reference's bits; rays that start on a triangle
// (from its hit point) test the walk's margins.
TEST(ApiOneRay, GeneratedShapesGiveTheReferencesBits) {
  for (long long triangles : {2000LL, 30000LL}) {
    testing::TempDir dir;
    generate::Options g;
    g.spheres = 300, g.cylinders = 40, g.seed = 5 + std::uint64_t(triangles);
    std::ofstream(dir.path() + "/mesh.ply", std::ios::binary) << generate::sphere_ply(triangles);
    g.mesh_file = "mesh.ply";
    std::ofstream(dir.path() + "/scene.json") << generate::scene_json(g);
    const Scene s = load_scene(dir.path() + "/scene.json");
    ASSERT_FALSE(s.shapes.empty());
    for (Precision p : {Precision::exact, Precision::dbl})
      compare(s, p, 6000, std::uint64_t(triangles), "shapes " + std::to_string(triangles));
  }
}

// Packets of four rays from each of four hit points, as ambient occlusion and diffuse bounces
// cast them (bench --mode ao, diffuse): from kClusteredMinSpheres spheres a packet whose lanes
// leave from within one leaf box walks clustered (Hybrid::secondary_walk: as a packet until few
// lanes enter a subtree), the other packets' lanes whole below kOneRayMinSpheres and alone from
// it; every lane's closest hit and occlusion the reference's bits, at every packet width (a
// narrower kernel takes the packet in chunks: one or two points each), exact and double.
TEST(ApiOneRay, RaysFromCommonPointsGiveTheReferencesBits) {
  for (int spheres : {kClusteredMinSpheres + 500, kOneRayMinSpheres + 1000})
    for (Precision p : {Precision::exact, Precision::dbl}) {
      const Scene desc = cloud(spheres, 11);
      SCOPED_TRACE(std::to_string(spheres) + " spheres");
      const api::Scene ref = api::Scene::from_description(desc, with(p, 1));
      std::vector<api::Ray16> packets;
      std::mt19937_64 g(5);
      api::Ray16 r;
      int lane = 0;
      const int nx = ref.info().nx, ny = ref.info().ny;
      // Neighbouring pixels' hits (four in a row, then 12 skipped), mostly within one leaf box.
      for (int j = 0; j < ny && packets.size() < 400; j += 3)
        for (int i = 0; i < nx && packets.size() < 400; i += i % 16 == 3 ? 13 : 1) {
          Ray cam;
          ref.camera_ray(i, j, 0, 0, cam.o, cam.d);
          const Answer a = one(ref, cam);
          if (a.hit.id[0] < 0) continue;
          const float n[3] = {a.hit.ng_x[0], a.hit.ng_y[0], a.hit.ng_z[0]};
          const float side = n[0] * cam.d[0] + n[1] * cam.d[1] + n[2] * cam.d[2] > 0 ? -1.f : 1.f;
          for (int q = 0; q < 4; ++q) {
            Ray x;
            for (int k = 0; k < 3; ++k)
              x.o[k] = cam.o[k] + a.hit.t[0] * cam.d[k] + side * 1e-3f * n[k];
            unit(x.d, g);
            if ((x.d[0] * n[0] + x.d[1] * n[1] + x.d[2] * n[2]) * side < 0)
              for (float& c : x.d) c = -c;
            x.tfar = q == 3 ? 0.75f : kInf;  // one ray of four bounded, as an occlusion ray
            set_lane(r, lane++, x);
          }
          if (lane == 16) packets.push_back(r), lane = 0;
        }
      ASSERT_GE(packets.size(), 100u);
      for (int width : packet::supported_widths(p)) {
        const api::Scene fast = api::Scene::from_description(desc, with(p, width));
        SCOPED_TRACE(std::string(to_string(p)) + " width " + std::to_string(width));
        int differ = 0;
        std::size_t hits = 0;
        for (std::size_t i = 0; i < packets.size() && differ < 5; ++i) {
          api::Hit16 a, b;
          int oa[16], ob[16];
          fast.intersect(nullptr, packets[i], a), ref.intersect(nullptr, packets[i], b);
          fast.occluded(nullptr, packets[i], oa), ref.occluded(nullptr, packets[i], ob);
          for (int k = 0; k < 16; ++k) {
            const bool same_hit = a.id[k] == b.id[k] && same_bits(a.t[k], b.t[k]) &&
                                  same_bits(a.ng_x[k], b.ng_x[k]) &&
                                  same_bits(a.ng_y[k], b.ng_y[k]) &&
                                  same_bits(a.ng_z[k], b.ng_z[k]);
            EXPECT_TRUE(same_hit) << "packet " << i << " lane " << k << ": id " << a.id[k] << " vs "
                                  << b.id[k] << ", t " << a.t[k] << " vs " << b.t[k];
            EXPECT_EQ(oa[k], ob[k]) << "packet " << i << " lane " << k;
            differ += !same_hit || oa[k] != ob[k];
            hits += b.id[k] >= 0;
          }
        }
        // Rays that find a sphere and rays that leave the cloud.
        EXPECT_GT(hits, packets.size() * 16 / 10);
        EXPECT_LT(hits, packets.size() * 16);
      }
    }
}

// Every sphere twice (the copy's id higher): each hit ties on t, and the lower id must win
// wherever the walk meets the copy first (the copy in another leaf, or the same leaf's block).
TEST(ApiOneRay, TwinSpheresTieToTheLowerId) {
  for (long long n : {600LL, 9000LL}) {
    Scene s = cloud(n, 3 + std::uint64_t(n));
    const std::size_t count = s.spheres.size();
    for (std::size_t k = 0; k < count; ++k) s.spheres.push_back(s.spheres[k]);
    for (Precision p : {Precision::exact, Precision::dbl})
      compare(s, p, 4000, std::uint64_t(n) + 1, "twins " + std::to_string(n));
  }
}

TEST(ApiOneRay, InfoNamesThePath) {
  const Scene s = cloud(64, 3);
  const api::Scene ref = api::Scene::from_description(s, with(Precision::exact, 1));
  EXPECT_EQ(ref.info().one_ray, "scalar");
  const api::Scene fast = api::Scene::from_description(s, with(Precision::exact));
  // Fast mode answers one-ray queries in packets (where the machine runs any).
  if (!packet::supported_widths(Precision::fast).empty()) {
    const api::Scene fast_mode = api::Scene::from_description(s, with(Precision::fast));
    EXPECT_EQ(fast_mode.info().one_ray, "scalar");
  }
  if (fast.info().width >= 8) {
    EXPECT_TRUE(fast.info().one_ray == "avx2" || fast.info().one_ray == "avx512f")
        << fast.info().one_ray;
  }
}

// One sphere of radius 1 at the origin (and a plane below): rays that touch it, rays along the
// axes, rays from far beyond the origin limit (padded boxes) and the far limit (no hierarchy).
TEST(ApiOneRay, EdgesGiveTheReferencesBits) {
  Scene s = cloud(40, 5);
  s.spheres[0].center = {0, 0, 0};
  s.spheres[0].radius = 1;
  for (Precision p : {Precision::exact, Precision::dbl}) {
    const api::Scene fast = api::Scene::from_description(s, with(p));
    const api::Scene ref = api::Scene::from_description(s, with(p, 1));
    std::vector<Ray> rays;
    for (float far : {10.0f, 1e6f, 1e12f, 1e17f, 1e19f, 1e21f})
      for (int a = 0; a < 3; ++a)
        for (float sign : {-1.0f, 1.0f}) {
          // Along axis a towards the sphere, offset sideways by exactly the radius (tangent),
          // just inside, and through the centre.
          // Beyond it too: from far away float's rounding of the sphere test finds hits a long
          // way off the surface, which only the hierarchy's padded boxes keep.
          for (float side : {0.0f, 0.5f, 1.0f, 1.0000001f, 1.5f, 3.0f, 10.0f, 100.0f, 1e3f}) {
            Ray r;
            for (int k = 0; k < 3; ++k) r.o[k] = 0, r.d[k] = 0;
            r.o[a] = -sign * far;
            r.o[(a + 1) % 3] = side;
            r.d[a] = sign;
            rays.push_back(r);
          }
        }
    // Obliquely from far away, aimed at points at and around the surface: the origin's rounding
    // moves the ray by up to its ulp.
    std::mt19937_64 g(91);
    for (float far : {1e3f, 1e5f, 1e7f, 1e9f, 1e12f, 1e15f})
      for (int k = 0; k < 40; ++k) {
        Ray r;
        unit(r.d, g);
        const float aim = 0.9f + 0.01f * float(k % 20);  // a point at 0.9 .. 1.09 radii
        float side[3] = {r.d[1], -r.d[0], 0};
        const float sl = std::sqrt(side[0] * side[0] + side[1] * side[1]);
        for (int a = 0; a < 3; ++a)
          r.o[a] = (sl > 0 ? aim * side[a] / sl : (a == 0 ? aim : 0)) - far * r.d[a];
        rays.push_back(r);
      }
    int hits = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
      const Answer a = one(fast, rays[i]), b = one(ref, rays[i]);
      EXPECT_TRUE(same(a, b)) << "ray " << i << " from " << rays[i].o[0] << ", " << rays[i].o[1]
                              << ", " << rays[i].o[2];
      hits += b.hit.id[0] == 0;
    }
    EXPECT_GT(hits, 0);  // the edge rays do reach the sphere
  }
}

}  // namespace
}  // namespace lancer
