// The library API's per-ray fields beyond origin, direction and tfar: tnear, the ray mask, and
// the hit's primitive id and u, v, on spheres and planes, at every packet width.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "api/api_util.hpp"
#include "lancer/lancer.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

using testing::with;
constexpr float kInf = std::numeric_limits<float>::infinity();

bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

struct Ray {
  Vec3<double> org, dir;
  float tnear = 0, tfar = kInf;
  unsigned mask = api::kAllObjects;
};

struct Hit {
  float t, u, v, ng[3];
  int id, prim_id, occluded;
};

// One ray in lane `lane` of a packet of N whose other lanes carry other rays (so that the
// packet kernels see a mixed packet), traced through intersect and occluded.
template <int N>
Hit trace(const api::Scene& scene, const Ray& ray, int lane) {
  api::RayPacket<N> r;
  for (int k = 0; k < N; ++k) {
    const Vec3<double> d = k == lane ? ray.dir : normalize(Vec3<double>{0.1 * k, -0.2, -1});
    const Vec3<double> o = k == lane ? ray.org : Vec3<double>{0, 0, 5};
    r.org_x[k] = float(o.x), r.org_y[k] = float(o.y), r.org_z[k] = float(o.z);
    r.dir_x[k] = float(d.x), r.dir_y[k] = float(d.y), r.dir_z[k] = float(d.z);
    r.tnear[k] = k == lane ? ray.tnear : 0;
    r.tfar[k] = k == lane ? ray.tfar : kInf;
    r.mask[k] = k == lane ? ray.mask : api::kAllObjects;
  }
  api::HitPacket<N> h;
  int occluded[N];
  scene.intersect(nullptr, r, h);
  scene.occluded(nullptr, r, occluded);
  return {h.t[lane],  h.u[lane],       h.v[lane],     {h.ng_x[lane], h.ng_y[lane], h.ng_z[lane]},
          h.id[lane], h.prim_id[lane], occluded[lane]};
}

// The same ray at every packet width and in every lane place gives the same bits.
Hit trace_everywhere(const api::Scene& scene, const Ray& ray) {
  const Hit one = trace<1>(scene, ray, 0);
  for (const Hit& other : {trace<4>(scene, ray, 2), trace<8>(scene, ray, 7),
                           trace<16>(scene, ray, 0), trace<16>(scene, ray, 9)}) {
    EXPECT_TRUE(same_bits(other.t, one.t)) << other.t << " vs " << one.t;
    EXPECT_EQ(other.id, one.id);
    EXPECT_EQ(other.prim_id, one.prim_id);
    EXPECT_EQ(other.occluded, one.occluded);
    for (int a = 0; a < 3; ++a) EXPECT_TRUE(same_bits(other.ng[a], one.ng[a]));
    EXPECT_TRUE(same_bits(other.u, one.u) && same_bits(other.v, one.v));
  }
  return one;
}

// scenes/lorenzi-shadows.json: spheres 0-2 (sphere 1 at (-1, -1, -3), radius 1), then the
// plane y = -2 (id 3), camera at (0, 0, 5).
TEST(ApiRays, TnearUvAndPrimIdOnSpheresAndPlanes) {
  const std::string file = testing::source_path("scenes/lorenzi-shadows.json");
  for (const api::Options& opt :
       {with(Precision::exact), with(Precision::dbl), with(Precision::exact, 1)}) {
    SCOPED_TRACE(to_string(opt.precision) + std::string(" width ") + std::to_string(opt.width));
    const api::Scene scene = api::Scene::load(file, opt);
    const Vec3<double> eye{0, 0, 5}, centre{-1, -1, -3};
    const double dist = length(centre - eye);
    Ray ray;
    ray.org = eye, ray.dir = normalize(centre - eye);

    // Through sphere 1's centre: in at dist - 1, out at dist + 1, then down to the plane.
    const Hit front = trace_everywhere(scene, ray);
    EXPECT_EQ(front.id, 1);
    EXPECT_EQ(front.prim_id, 0);
    EXPECT_EQ(front.u, 0.0f);
    EXPECT_EQ(front.v, 0.0f);
    EXPECT_NEAR(front.t, dist - 1, 1e-5);
    EXPECT_EQ(front.occluded, 1);

    ray.tnear = float(dist);  // inside the sphere: its far side
    const Hit back = trace_everywhere(scene, ray);
    EXPECT_EQ(back.id, 1);
    EXPECT_EQ(back.prim_id, 0);
    EXPECT_NEAR(back.t, dist + 1, 1e-5);
    EXPECT_NEAR(back.ng[0] * ray.dir.x + back.ng[1] * ray.dir.y + back.ng[2] * ray.dir.z, 1.0,
                1e-5);  // outward, along the ray where it leaves
    EXPECT_EQ(back.occluded, 1);

    ray.tnear = float(dist + 1.5);  // beyond the sphere: the plane
    const Hit plane = trace_everywhere(scene, ray);
    EXPECT_EQ(plane.id, 3);
    EXPECT_EQ(plane.prim_id, 0);
    EXPECT_EQ(plane.u, 0.0f);
    EXPECT_EQ(plane.v, 0.0f);
    EXPECT_NEAR(plane.t, 2 / -ray.dir.y, 1e-4);  // from y = 0 down to -2
    EXPECT_EQ(plane.ng[1], 1.0f);

    ray.tnear = std::nextafter(plane.t, kInf);  // beyond the plane too: nothing
    const Hit none = trace_everywhere(scene, ray);
    EXPECT_EQ(none.id, -1);
    EXPECT_EQ(none.prim_id, -1);
    EXPECT_EQ(none.t, kInf);
    EXPECT_EQ(none.occluded, 0);

    ray.tnear = plane.t;  // t > tnear: the plane at exactly tnear does not count
    EXPECT_EQ(trace_everywhere(scene, ray).id, -1);

    ray.tnear = float(dist);  // tnear and tfar together: the far side lies beyond tfar
    ray.tfar = float(dist + 0.5);
    const Hit cut = trace_everywhere(scene, ray);
    EXPECT_EQ(cut.id, -1);
    EXPECT_EQ(cut.occluded, 0);

    ray.tnear = 0, ray.tfar = kInf, ray.mask = 0;  // a mask that sees no object
    const Hit masked = trace_everywhere(scene, ray);
    EXPECT_EQ(masked.id, -1);
    EXPECT_EQ(masked.occluded, 0);
    ray.mask = 0x10;
    EXPECT_EQ(trace_everywhere(scene, ray).id, 1);
  }
}

// A tnear beyond epsilon but before the nearest hit finds that same hit, bit for bit: the lanes
// with such a tnear go through the reference's walk, the others through the packet kernels,
// which are the reference's bits.
TEST(ApiRays, TnearBeforeTheNearestHitChangesNoBit) {
  for (const char* file : {"scenes/lorenzi-reflections.json", "scenes/many-spheres.json"}) {
    SCOPED_TRACE(file);
    const api::Scene scene = api::Scene::load(testing::source_path(file), with(Precision::exact));
    const api::Info& in = scene.info();
    std::mt19937 rng(7);
    int hits = 0;
    for (int i = 0; i < 20000 && hits < 100; ++i) {
      // Camera rays of random pixels, until 100 have hit something.
      float o[3], d[3];
      scene.camera_ray(int(rng() % in.nx), int(rng() % in.ny), 0, 0, o, d);
      Ray ray;
      ray.org = {o[0], o[1], o[2]}, ray.dir = {d[0], d[1], d[2]};
      const Hit first = trace<16>(scene, ray, i % 16);
      if (first.id < 0 || !(first.t * 0.5f > float(scene.description().epsilon))) continue;
      ++hits;
      ray.tnear = first.t * 0.5f;
      const Hit again = trace_everywhere(scene, ray);
      EXPECT_TRUE(same_bits(again.t, first.t)) << again.t << " vs " << first.t;
      EXPECT_EQ(again.id, first.id);
      for (int a = 0; a < 3; ++a) EXPECT_TRUE(same_bits(again.ng[a], first.ng[a]));
    }
    EXPECT_EQ(hits, 100);
  }
}

TEST(ApiRays, NanTnearIsAnErrorNamingTheLane) {
  const api::Scene scene =
      api::Scene::load(testing::source_path("scenes/lorenzi-shadows.json"), with(Precision::exact));
  api::Ray8 r{};
  for (int k = 0; k < 8; ++k) r.dir_z[k] = -1, r.tfar[k] = kInf, r.mask[k] = api::kAllObjects;
  r.tnear[5] = std::nanf("");
  api::Hit8 h;
  EXPECT_EQ(testing::error_of([&] { scene.intersect(nullptr, r, h); }),
            "intersect: lane 5: tnear is NaN");
}

// Packets are laid out for aligned vector loads, as Embree's.
static_assert(alignof(api::Ray16) == 64 && alignof(api::Hit16) == 64 && alignof(api::Ray4) == 64);
static_assert(sizeof(api::Ray16) % 64 == 0 && sizeof(api::Hit8) % 64 == 0);

}  // namespace
}  // namespace lancer
