// The library API's per-ray fields beyond origin, direction and tfar: tnear, the ray mask, and
// the hit's primitive id, u, v and normal, on spheres and planes and on triangles, meshes and
// cylinders, at every packet width.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <random>
#include <string>
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

// A scene whose objects are sphere 0, plane 1 (y = -50), a lone triangle 2, a mesh 3 and a
// capped cylinder 4 (axis x = -6, z = -3, y from -1 to 1, radius 1). The mesh's faces, in file
// order: triangle 0 at z = -1 (counter-clockwise seen from +z), triangle 1 at z = -2 (clockwise),
// a zero-area face (dropped, not counted) and a quad at z = -3 (fan triangles 2 and 3).
struct ShapeScene {
  testing::TempDir dir;
  std::string path = dir.file("shapes.json");
  ShapeScene() {
    std::ofstream(dir.file("m.obj")) << "v -1 -1 -1\nv 3 -1 -1\nv -1 3 -1\n"
                                        "v -1 -1 -2\nv 3 -1 -2\nv -1 3 -2\n"
                                        "v -1 -1 -3\nv 3 -1 -3\nv 3 3 -3\nv -1 3 -3\n"
                                        "v 1 -1 -1\n"
                                        "f 1 2 3\nf 4 6 5\nf 1 11 2\nf 7 8 9 10\n";
    std::ofstream(path) << R"({
      "camera": {"position": [0, 0, 5], "direction": [0, 0, -1], "distance": 1,
                 "resolution": [8, 8], "bounds": [-1, 1, -1, 1]},
      "objects": [
        {"type": "sphere", "center": [20, 20, 20], "radius": 1},
        {"type": "plane", "point": [0, -50, 0], "normal": [0, 1, 0]},
        {"type": "triangle", "vertices": [[9, -1, -1], [11, -1, -1], [9, 1, -1]]},
        {"type": "mesh", "file": "m.obj"},
        {"type": "cylinder", "base": [-6, -1, -3], "top": [-6, 1, -3], "radius": 1}]})";
  }
};

// The ray from `from` through `at`, and the distance between them.
Ray aimed(const Vec3<double>& from, const Vec3<double>& at, double& dist) {
  Ray r;
  r.org = from, r.dir = normalize(at - from), dist = length(at - from);
  return r;
}

void expect_normal(const Hit& h, const Vec3<double>& n) {
  EXPECT_NEAR(h.ng[0], n.x, 1e-6);
  EXPECT_NEAR(h.ng[1], n.y, 1e-6);
  EXPECT_NEAR(h.ng[2], n.z, 1e-6);
}

// The mesh's triangle `prim` hit at `at` by `ray`, `dist` along it: prim_id, Embree's u, v (the
// weights of v1 and v2, checked against the expected ones and by rebuilding the point from the
// corners), t and the geometric normal.
void expect_triangle(const Hit& h, const Ray& ray, int id, int prim, const Vec3<double> (&v)[3],
                     double u, double vv, double dist, const Vec3<double>& n) {
  EXPECT_EQ(h.id, id);
  EXPECT_EQ(h.prim_id, prim);
  EXPECT_NEAR(h.u, u, 1e-5);
  EXPECT_NEAR(h.v, vv, 1e-5);
  EXPECT_NEAR(h.t, dist, 1e-4);
  const Vec3<double> rebuilt = v[0] * (1.0 - h.u - h.v) + v[1] * double(h.u) + v[2] * double(h.v);
  EXPECT_NEAR(length(rebuilt - (ray.org + ray.dir * double(h.t))), 0.0, 1e-4);
  expect_normal(h, n);
  EXPECT_EQ(h.occluded, 1);
}

TEST(ApiRays, TrianglesMeshesAndCylindersGiveEmbreesHitFields) {
  const ShapeScene file;
  for (const api::Options& opt : {with(Precision::exact), with(Precision::dbl)}) {
    SCOPED_TRACE(to_string(opt.precision));
    const api::Scene scene = api::Scene::load(file.path, opt);
    ASSERT_EQ(scene.info().objects, 5);
    const Vec3<double> tri0[3] = {{-1, -1, -1}, {3, -1, -1}, {-1, 3, -1}};
    const Vec3<double> tri1[3] = {{-1, -1, -2}, {-1, 3, -2}, {3, -1, -2}};
    const Vec3<double> tri2[3] = {{-1, -1, -3}, {3, -1, -3}, {3, 3, -3}};
    const Vec3<double> tri3[3] = {{-1, -1, -3}, {3, 3, -3}, {-1, 3, -3}};
    const Vec3<double> up{0, 0, 1}, down{0, 0, -1};

    // An oblique ray through (0.5, -0.5) on z = -1; each unit of depth moves it (0.1, 0.25).
    const Vec3<double> step{0.1, 0.25, -1}, p0{0.5, -0.5, -1};
    double d0;
    Ray ray = aimed(p0 - step * 6.0, p0, d0);
    const double dz = length(step);  // the distance from one z plane to the next
    expect_triangle(trace_everywhere(scene, ray), ray, 3, 0, tri0, 0.375, 0.125, d0, up);
    // tnear past each triangle finds the next one along the ray.
    ray.tnear = float(d0 + 0.5 * dz);
    expect_triangle(trace_everywhere(scene, ray), ray, 3, 1, tri1, 0.1875, 0.4, d0 + dz, down);
    ray.tnear = float(d0 + 1.5 * dz);  // (0.7, 0, -3): below the quad's diagonal
    expect_triangle(trace_everywhere(scene, ray), ray, 3, 2, tri2, 0.175, 0.25, d0 + 2 * dz, up);
    ray.tnear = float(d0 + 2.5 * dz);
    const Hit none = trace_everywhere(scene, ray);
    EXPECT_EQ(none.id, -1);
    EXPECT_EQ(none.prim_id, -1);
    EXPECT_EQ(none.occluded, 0);

    // Straight down at (1, 2.5): outside triangles 0 and 1, above the quad's diagonal.
    double d3;
    ray = aimed({1, 2.5, 4}, {1, 2.5, -3}, d3);
    expect_triangle(trace_everywhere(scene, ray), ray, 3, 3, tri3, 0.5, 0.375, d3, up);

    // The lone triangle is object 2's one primitive.
    const Vec3<double> lone[3] = {{9, -1, -1}, {11, -1, -1}, {9, 1, -1}};
    double dl;
    ray = aimed({8, 0, 3}, {9.5, -0.75, -1}, dl);
    expect_triangle(trace_everywhere(scene, ray), ray, 2, 0, lone, 0.25, 0.125, dl, up);

    // The cylinder: its side (outward from the axis), top cap (+axis) and base (-axis).
    struct CylinderCase {
      Ray ray;
      double t;
      Vec3<double> ng;
    };
    const Vec3<double> side{-6 + 0.6, 0.3, -3 + 0.8},
        towards = normalize(Vec3<double>{0.2, -0.1, -1});
    double dist;
    const CylinderCase cases[] = {
        {aimed(side - towards * 5.0, side, dist), 5.0, {0.6, 0, 0.8}},
        {aimed({-6.2, 5, -3.1}, {-6.2, 1, -3.1}, dist), 4.0, {0, 1, 0}},
        {aimed({-5.7, -5, -3.3}, {-5.7, -1, -3.3}, dist), 4.0, {0, -1, 0}}};
    for (const CylinderCase& c : cases) {
      SCOPED_TRACE("cylinder, normal (" + std::to_string(c.ng.x) + ", " + std::to_string(c.ng.y) +
                   ", " + std::to_string(c.ng.z) + ")");
      const Hit h = trace_everywhere(scene, c.ray);
      EXPECT_EQ(h.id, 4);
      EXPECT_EQ(h.prim_id, 0);
      EXPECT_EQ(h.u, 0.0f);
      EXPECT_EQ(h.v, 0.0f);
      EXPECT_NEAR(h.t, c.t, 1e-4);
      expect_normal(h, c.ng);
    }
  }
}

// Packets are laid out for aligned vector loads, as Embree's.
static_assert(alignof(api::Ray16) == 64 && alignof(api::Hit16) == 64 && alignof(api::Ray4) == 64);
static_assert(sizeof(api::Ray16) % 64 == 0 && sizeof(api::Hit8) % 64 == 0);

// Rays packed N to a packet, every lane active: each lane's hit fields against the same ray
// alone at width 1 (the scalar world_normal's). Counts the rays whose id is in [lo, hi).
template <int N>
int packed_like_alone(const api::Scene& scene, const std::vector<Ray>& rays, int lo, int hi) {
  int in_range = 0;
  for (std::size_t base = 0; base + N <= rays.size(); base += N) {
    api::RayPacket<N> r;
    for (int k = 0; k < N; ++k) {
      const Ray& ray = rays[base + k];
      r.org_x[k] = float(ray.org.x), r.org_y[k] = float(ray.org.y), r.org_z[k] = float(ray.org.z);
      r.dir_x[k] = float(ray.dir.x), r.dir_y[k] = float(ray.dir.y), r.dir_z[k] = float(ray.dir.z);
      r.tnear[k] = ray.tnear, r.tfar[k] = ray.tfar, r.mask[k] = ray.mask;
    }
    api::HitPacket<N> h;
    scene.intersect(nullptr, r, h);
    for (int k = 0; k < N; ++k) {
      const Hit one = trace<1>(scene, rays[base + k], 0);
      SCOPED_TRACE(::testing::Message() << "width " << N << " ray " << base + k);
      EXPECT_EQ(h.id[k], one.id);
      EXPECT_TRUE(same_bits(h.t[k], one.t));
      EXPECT_TRUE(same_bits(h.ng_x[k], one.ng[0]) && same_bits(h.ng_y[k], one.ng[1]) &&
                  same_bits(h.ng_z[k], one.ng[2]))
          << h.ng_x[k] << " " << h.ng_y[k] << " " << h.ng_z[k] << " vs " << one.ng[0] << " "
          << one.ng[1] << " " << one.ng[2];
      EXPECT_EQ(h.prim_id[k], one.prim_id);
      EXPECT_TRUE(same_bits(h.u[k], one.u) && same_bits(h.v[k], one.v));
      in_range += h.id[k] >= lo && h.id[k] < hi;
    }
  }
  return in_range;
}

// The normals of full packets, computed a packet at a time, against the scalar ones lane by
// lane, on every kind of sphere normal: tiny spheres far away (p relative to the sphere), a
// huge ground sphere seen from close above (t recomputed), ordinary spheres and a plane, in
// one rotated frame, the kinds mixed within packets.
TEST(ApiRays, PacketNormalsOfEverySphereKindAreTheScalarOnes) {
  Scene d;
  d.name = "kinds.json";
  d.camera.position = {3.5, 1.25, -2};
  d.camera.direction = {0.3, -0.2, -1};
  d.camera.nx = d.camera.ny = 8;
  d.materials.push_back(Material{});
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 12; ++i) {  // ids 0-11: radius 0.01, about 300 away (small)
    Sphere s;
    s.center = d.camera.position + Vec3<double>{u(rng) * 30, u(rng) * 30, -300 + u(rng) * 20};
    s.radius = 0.01;
    d.spheres.push_back(s);
  }
  for (int i = 0; i < 4; ++i) {  // ids 12-15: ordinary
    Sphere s;
    s.center = d.camera.position + Vec3<double>{u(rng) * 3, u(rng) * 2, -8 + u(rng)};
    s.radius = 0.7;
    d.spheres.push_back(s);
  }
  Sphere ground;  // id 16: radius 1e6, its top 3 below the camera (large)
  ground.center = d.camera.position + Vec3<double>{0, -3 - 1e6, 0};
  ground.radius = 1e6;
  d.spheres.push_back(ground);
  Plane wall;  // id 17
  wall.point = d.camera.position + Vec3<double>{-6, 0, 0};
  wall.normal = {1, 0.1, 0};
  d.planes.push_back(wall);
  std::vector<Ray> rays;
  for (int i = 0; i < 32 * 16; ++i) {
    Ray ray;
    ray.org = d.camera.position + Vec3<double>{u(rng), u(rng), u(rng)} * 0.5;
    const int kind = i % 4;
    Vec3<double> to;
    if (kind == 0)  // a tiny sphere, within a radius of its centre
      to = d.spheres[rng() % 12].center + Vec3<double>{u(rng), u(rng), u(rng)} * 0.006;
    else if (kind == 1)
      to = d.spheres[12 + rng() % 4].center + Vec3<double>{u(rng), u(rng), u(rng)} * 0.5;
    else if (kind == 2)  // the ground
      to = ray.org + Vec3<double>{u(rng) * 4, -3, u(rng) * 4};
    else  // anywhere: the wall, the ground, misses
      to = ray.org + Vec3<double>{u(rng), u(rng), u(rng)};
    ray.dir = normalize(to - ray.org);
    rays.push_back(ray);
  }
  for (Precision p : {Precision::exact, Precision::dbl}) {
    SCOPED_TRACE(to_string(p));
    const api::Scene scene = api::Scene::from_description(d, with(p));
    const int small = packed_like_alone<16>(scene, rays, 0, 12);
    EXPECT_GT(small, 32);  // the rays meet every kind
    EXPECT_GT(packed_like_alone<16>(scene, rays, 16, 17), 64);
    EXPECT_GT(packed_like_alone<16>(scene, rays, 17, 18), 8);
    EXPECT_EQ(packed_like_alone<8>(scene, rays, 0, 12), small);
    EXPECT_EQ(packed_like_alone<4>(scene, rays, 0, 12), small);
  }
}

// Triangles, meshes and cylinders through the packet kernels: every hit field of full packets
// (prim_id, u, v and the normal from the kernel's primitive; t and id its own) against the
// same ray alone at width 1, on the shape scene above and on the shipped ones, exact and double.
TEST(ApiRays, PacketsOfTrianglesMeshesAndCylindersGiveTheReferencesFields) {
  LANCER_SKIP_WITHOUT_PACKETS();
  const ShapeScene file;
  for (const std::string& path : {file.path, testing::source_path("scenes/prims/glass-mesh.json"),
                                  testing::source_path("scenes/prims/cylinders.json")}) {
    for (Precision p : {Precision::exact, Precision::dbl}) {
      SCOPED_TRACE(path + " " + to_string(p));
      const api::Scene scene = api::Scene::load(path, with(p));
      EXPECT_GT(scene.info().width, 1);
      const api::SceneDescription& d = scene.description();
      const int first_shape = int(d.spheres.size() + d.planes.size());
      // Camera rays through random points of the image, from points near the eye.
      std::mt19937 rng(17);
      std::uniform_real_distribution<double> u(0, 1);
      std::vector<Ray> rays;
      float o[3], dir[3];
      for (int i = 0; i < 16 * 40; ++i) {
        scene.camera_ray(int(u(rng) * scene.info().nx), int(u(rng) * scene.info().ny), 0, 0, o,
                         dir);
        Ray ray;
        ray.org = {o[0] + 0.01 * u(rng), o[1], o[2]};
        ray.dir = normalize(Vec3<double>{dir[0], dir[1], dir[2]});
        rays.push_back(ray);
      }
      const int shapes = packed_like_alone<16>(scene, rays, first_shape, 1 << 30);
      EXPECT_GT(shapes, 16);  // the rays meet the shapes
      EXPECT_EQ(packed_like_alone<8>(scene, rays, first_shape, 1 << 30), shapes);
      EXPECT_EQ(packed_like_alone<4>(scene, rays, first_shape, 1 << 30), shapes);
    }
  }
}

}  // namespace
}  // namespace lancer
