// The library API (include/lancer/lancer.hpp): world-space ray queries against the reference,
// occlusion against closest hit, every packet width against every other bit for bit, row
// renders against lancer::render, and bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <random>
#include <type_traits>

#include "api/api_util.hpp"
#include "lancer/lancer.hpp"
#include "lancer/prepared.hpp"
#include "lancer/reference.hpp"
#include "lancer/render.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

using api::Options;
using testing::error_of;
using testing::with;
constexpr float kInf = std::numeric_limits<float>::infinity();

bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// A flat list of rays, traced through packets of any width.
struct Rays {
  std::vector<float> org, dir, tfar;  // 3 per ray, 3 per ray, 1 per ray
  std::vector<int> valid;
  std::size_t size() const { return tfar.size(); }
  void add(const Vec3<double>& o, const Vec3<double>& d, float t = kInf, int v = -1) {
    const Vec3<double> u = normalize(d);
    org.insert(org.end(), {float(o.x), float(o.y), float(o.z)});
    dir.insert(dir.end(), {float(u.x), float(u.y), float(u.z)});
    tfar.push_back(t);
    valid.push_back(v);
  }
};

struct Results {
  std::vector<float> t, ng, uv;
  std::vector<int> id, occluded, prim;
};

// Traces every ray through packets of N lanes. Inactive lanes keep sentinels, which are checked.
template <int N>
Results trace(const api::Scene& scene, const Rays& rays) {
  Results out;
  const std::size_t n = rays.size();
  out.t.assign(n, 0), out.ng.assign(3 * n, 0), out.id.assign(n, 0), out.occluded.assign(n, 0);
  out.uv.assign(2 * n, 0), out.prim.assign(n, 0);
  for (std::size_t base = 0; base < n; base += N) {
    api::RayPacket<N> r;
    api::HitPacket<N> h;
    int valid[N], occ[N];
    for (int k = 0; k < N; ++k) {
      const std::size_t i = std::min(base + k, n - 1);
      r.org_x[k] = rays.org[3 * i], r.org_y[k] = rays.org[3 * i + 1];
      r.org_z[k] = rays.org[3 * i + 2];
      r.dir_x[k] = rays.dir[3 * i], r.dir_y[k] = rays.dir[3 * i + 1];
      r.dir_z[k] = rays.dir[3 * i + 2];
      r.tfar[k] = rays.tfar[i];
      r.tnear[k] = 0, r.mask[k] = api::kAllObjects;
      valid[k] = base + k < n ? rays.valid[i] : 0;
      h.t[k] = 1234.5f, h.id[k] = h.prim_id[k] = 77, h.ng_x[k] = h.ng_y[k] = h.ng_z[k] = 9;
      h.u[k] = h.v[k] = 9;
      occ[k] = 55;
    }
    scene.intersect(valid, r, h);
    scene.occluded(valid, r, occ);
    for (int k = 0; k < N && base + k < n; ++k) {
      const std::size_t i = base + k;
      if (!valid[k]) {
        EXPECT_TRUE(h.t[k] == 1234.5f && h.id[k] == 77 && h.ng_x[k] == 9 && occ[k] == 55 &&
                    h.prim_id[k] == 77 && h.u[k] == 9 && h.v[k] == 9)
            << "inactive lane " << k << " was written";
        out.id[i] = -2;  // inactive
        continue;
      }
      out.t[i] = h.t[k], out.id[i] = h.id[k], out.occluded[i] = occ[k];
      out.ng[3 * i] = h.ng_x[k], out.ng[3 * i + 1] = h.ng_y[k], out.ng[3 * i + 2] = h.ng_z[k];
      out.uv[2 * i] = h.u[k], out.uv[2 * i + 1] = h.v[k], out.prim[i] = h.prim_id[k];
    }
  }
  return out;
}

Results trace(const api::Scene& scene, const Rays& rays, int n) {
  switch (n) {
    case 1:
      return trace<1>(scene, rays);
    case 4:
      return trace<4>(scene, rays);
    case 8:
      return trace<8>(scene, rays);
    default:
      return trace<16>(scene, rays);
  }
}

// Rays from random points near the camera in random directions, a quarter of lanes inactive,
// half of them with a finite tfar.
Rays random_rays(const api::Scene& scene, unsigned seed, std::size_t count, double spread) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1), t(0.01, 20);
  const Vec3<double> eye = scene.description().camera.position;
  Rays rays;
  for (std::size_t i = 0; i < count; ++i) {
    const Vec3<double> o = eye + Vec3<double>{u(rng), u(rng), u(rng)} * spread;
    // Half in any direction, half towards a sphere (near its edge as often as not).
    const auto& spheres = scene.description().spheres;
    Vec3<double> d{u(rng), u(rng), u(rng)};
    if ((i & 1) && !spheres.empty()) {
      const Sphere& s = spheres[rng() % spheres.size()];
      d = s.center + Vec3<double>{u(rng), u(rng), u(rng)} * s.radius - o;
    }
    if (!(dot(d, d) > 1e-6)) d = {0, 0, -1};
    rays.add(o, d, (rng() & 1) ? kInf : float(t(rng)), (rng() & 3) ? -1 : 0);
  }
  return rays;
}

// Every packet width the API takes gives the same bits: distances, ids, normals, occlusion.
// In exact and double precision, with the scene's widest kernel and with it pinned narrower.
TEST(Api, EveryPacketWidthGivesTheSameBits) {
  for (const char* file : {"scenes/lorenzi-reflections.json", "scenes/many-spheres.json"}) {
    for (Options opt : {with(Precision::exact), with(Precision::dbl), with(Precision::exact, 4)}) {
      const std::vector<int> widths = packet::supported_widths(opt.precision);
      if (opt.width && std::find(widths.begin(), widths.end(), opt.width) == widths.end())
        continue;  // a CPU (or LANCER_MAX_WIDTH) without the pinned width
      SCOPED_TRACE(::testing::Message()
                   << file << " " << to_string(opt.precision) << " width " << opt.width);
      const api::Scene scene = api::Scene::load(testing::source_path(file), opt);
      const Rays rays = random_rays(scene, 11, 2000, 3.0);
      const Results one = trace(scene, rays, 1);
      std::size_t hits = 0;
      for (int id : one.id) hits += id >= 0;
      EXPECT_GT(hits, rays.size() / 10);  // the rays meet the scene
      for (int n : {4, 8, 16}) {
        const Results r = trace(scene, rays, n);
        std::size_t differ = 0;
        for (std::size_t i = 0; i < rays.size(); ++i) {
          bool same = r.id[i] == one.id[i] && same_bits(r.t[i], one.t[i]) &&
                      r.occluded[i] == one.occluded[i];
          for (int a = 0; a < 3; ++a) same = same && same_bits(r.ng[3 * i + a], one.ng[3 * i + a]);
          differ += !same;
        }
        EXPECT_EQ(differ, 0u) << "width " << n;
      }
    }
  }
}

// A packet with most lanes active moves its rays into the scene's frame in vectors, one with a
// few lanes active moves those alone with Frame's own functions: the same bits either way. Each
// ray again alone in a packet of 16 whose other lanes hold garbage (NaN, infinities, zero
// directions: inactive, so neither checked nor traced), against the packets of rays.trace.
TEST(Api, FewActiveLanesGiveTheBitsOfFullPackets) {
  for (Options opt : {with(Precision::exact), with(Precision::dbl)}) {
    const api::Scene scene =
        api::Scene::load(testing::source_path("scenes/many-spheres.json"), opt);
    SCOPED_TRACE(to_string(opt.precision));
    for (double spread : {3.0, 300.0}) {
      Rays rays = random_rays(scene, 23, 400, spread);
      std::fill(rays.valid.begin(), rays.valid.end(), -1);
      const Results full = trace<16>(scene, rays);
      std::size_t differ = 0;
      for (std::size_t i = 0; i < rays.size(); ++i) {
        api::Ray16 r;
        api::Hit16 h;
        int valid[16] = {}, occ[16];
        for (int k = 0; k < 16; ++k) {
          r.org_x[k] = std::numeric_limits<float>::quiet_NaN(), r.org_y[k] = kInf;
          r.org_z[k] = 0, r.dir_x[k] = r.dir_y[k] = r.dir_z[k] = 0;
          r.tnear[k] = r.tfar[k] = std::numeric_limits<float>::quiet_NaN();
          r.mask[k] = api::kAllObjects;
        }
        const int k = int(i % 16);
        valid[k] = 1;
        r.org_x[k] = rays.org[3 * i], r.org_y[k] = rays.org[3 * i + 1];
        r.org_z[k] = rays.org[3 * i + 2];
        r.dir_x[k] = rays.dir[3 * i], r.dir_y[k] = rays.dir[3 * i + 1];
        r.dir_z[k] = rays.dir[3 * i + 2];
        r.tnear[k] = 0, r.tfar[k] = rays.tfar[i];
        scene.intersect(valid, r, h);
        scene.occluded(valid, r, occ);
        bool same = h.id[k] == full.id[i] && same_bits(h.t[k], full.t[i]) &&
                    occ[k] == full.occluded[i] && same_bits(h.ng_x[k], full.ng[3 * i]) &&
                    same_bits(h.ng_y[k], full.ng[3 * i + 1]) &&
                    same_bits(h.ng_z[k], full.ng[3 * i + 2]);
        differ += !same;
      }
      EXPECT_EQ(differ, 0u) << "spread " << spread;
    }
  }
}

// A plain packet of the kernel's width (every lane on, from tnear 0) is checked, moved, traced
// and written in one pass; one lane off sends the packet chunk by chunk. The same bits either
// way (every hit field), at every packet width, in exact and double, on a scene without and with
// a hierarchy, and on scenes of triangles, meshes and cylinders (whose lanes' fields the plain
// packet takes from the kernel's primitive, the chunked one from the reference or the kernel).
TEST(Api, PlainPacketsGiveTheBitsOfMixedOnes) {
  for (const char* file : {"scenes/lorenzi-reflections.json", "scenes/many-spheres.json",
                           "scenes/prims/glass-mesh.json", "scenes/prims/cylinders.json"}) {
    for (Options opt : {with(Precision::exact), with(Precision::dbl)}) {
      const api::Scene scene = api::Scene::load(testing::source_path(file), opt);
      Rays rays = random_rays(scene, 31, 1600, 3.0);
      std::fill(rays.valid.begin(), rays.valid.end(), -1);
      Rays mixed = rays;  // lane 0 of every packet of 16 off: no packet of 4, 8, 16 is plain
      for (std::size_t i = 0; i < mixed.size(); i += 16) mixed.valid[i] = 0;
      for (int n : {4, 8, 16}) {
        SCOPED_TRACE(::testing::Message()
                     << file << " " << to_string(opt.precision) << " width " << n);
        const Results plain = trace(scene, rays, n), part = trace(scene, mixed, n);
        std::size_t differ = 0, compared = 0, hits = 0;
        for (std::size_t i = 0; i < rays.size(); ++i) {
          if (part.id[i] == -2) continue;
          bool same = part.id[i] == plain.id[i] && same_bits(part.t[i], plain.t[i]) &&
                      part.occluded[i] == plain.occluded[i] && part.prim[i] == plain.prim[i];
          for (int a = 0; a < 3; ++a)
            same = same && same_bits(part.ng[3 * i + a], plain.ng[3 * i + a]);
          for (int a = 0; a < 2; ++a)
            same = same && same_bits(part.uv[2 * i + a], plain.uv[2 * i + a]);
          differ += !same, ++compared, hits += plain.id[i] >= 0;
        }
        EXPECT_EQ(differ, 0u);
        EXPECT_GT(compared, rays.size() / 2);
        EXPECT_GT(hits, compared / 20);
      }
    }
  }
}

// A bad ray in the last lane of a full packet of every width: the error names it, and no lane
// of the packet is written (the one-pass path refuses before tracing, as the chunked one does).
TEST(Api, BadRayInAFullPacketWritesNothing) {
  const api::Scene scene =
      api::Scene::load(testing::source_path("scenes/lorenzi-shadows.json"), with(Precision::exact));
  const auto check = [&](auto lanes) {
    constexpr int N = decltype(lanes)::value;
    api::RayPacket<N> r{};
    api::HitPacket<N> h;
    for (int k = 0; k < N; ++k) r.dir_z[k] = -1, r.tfar[k] = kInf, h.id[k] = 42;
    r.dir_x[N - 1] = 1;
    const std::string what =
        ": lane " + std::to_string(N - 1) + ": dir must be unit length, |dir|^2 = 2.000000";
    EXPECT_EQ(error_of([&] { scene.intersect(nullptr, r, h); }), "intersect" + what);
    for (int k = 0; k < N; ++k) EXPECT_EQ(h.id[k], 42) << "width " << N << " lane " << k;
    int occ[N];
    std::fill(occ, occ + N, 42);
    EXPECT_EQ(error_of([&] { scene.occluded(nullptr, r, occ); }), "occluded" + what);
    for (int k = 0; k < N; ++k) EXPECT_EQ(occ[k], 42) << "width " << N << " lane " << k;
  };
  check(std::integral_constant<int, 4>{});
  check(std::integral_constant<int, 8>{});
  check(std::integral_constant<int, 16>{});
}

// Occluded before tfar exactly where the closest hit (with tfar infinite) lies before tfar.
TEST(Api, OcclusionAgreesWithClosestHit) {
  for (Options opt : {with(Precision::exact), with(Precision::dbl)}) {
    const api::Scene scene =
        api::Scene::load(testing::source_path("scenes/lorenzi-reflections.json"), opt);
    Rays rays = random_rays(scene, 5, 3000, 4.0);
    Rays open = rays;
    std::fill(open.tfar.begin(), open.tfar.end(), kInf);
    for (int n : {1, 4, 8, 16}) {
      SCOPED_TRACE(::testing::Message() << to_string(opt.precision) << " width " << n);
      const Results limited = trace(scene, rays, n), nearest = trace(scene, open, n);
      std::size_t blocked = 0, differ = 0;
      for (std::size_t i = 0; i < rays.size(); ++i) {
        if (limited.id[i] == -2) continue;
        const bool expect = nearest.id[i] >= 0 && nearest.t[i] < rays.tfar[i];
        differ += (limited.occluded[i] != 0) != expect;
        blocked += expect;
        // With a finite tfar the closest hit is the same hit, or none.
        if (expect) {
          EXPECT_EQ(limited.id[i], nearest.id[i]);
        } else {
          EXPECT_EQ(limited.id[i], -1);
        }
      }
      EXPECT_EQ(differ, 0u);
      EXPECT_GT(blocked, 100u);
    }
  }
}

// A scene 1e5 away from the world's origin, queried with world-space rays from near its
// camera. The API moves origins (and turns directions) into the prepared frame in double: hits are
// the reference's, bit for bit, on the same prepared values, and the double reference's objects.
// Passing the world-space rays to the kernels unconverted (the old closest_hit_packet trap) misses.
TEST(Api, WorldSpaceRaysFarFromTheOriginHitWhatTheReferenceHits) {
  const Vec3<double> far{1e5 + 0.3, -2e5 + 0.7, 3e5 + 0.1};
  Scene d;
  d.name = "far.json";
  d.camera.position = far;
  // A camera that looks along no axis: the prepared frame is rotated as well as moved.
  d.camera.direction = {0.3, -0.2, -1};
  d.camera.nx = d.camera.ny = 8;
  d.materials.push_back(Material{});
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 20; ++i) {
    Sphere s;
    s.center = far + Vec3<double>{u(rng) * 20, u(rng) * 20, -30 + u(rng) * 10};
    s.radius = 0.5 + 0.5 * (u(rng) + 1);
    d.spheres.push_back(s);
  }
  Plane ground;
  ground.point = far + Vec3<double>{0, -25, 0};
  d.planes.push_back(ground);
  for (Precision p : {Precision::exact, Precision::dbl}) {
    SCOPED_TRACE(to_string(p));
    const api::Scene scene = api::Scene::from_description(d, with(p));
    // The queries' frame: this camera looks off the axes, so the world's axes at the eye.
    const auto pf = prepare<float>(scene.description(), Accel::automatic, FrameKind::query);
    const auto pd = prepare<double>(scene.description(), Accel::automatic, FrameKind::query);
    ASSERT_FALSE(pf.frame.turned);
    ASSERT_TRUE(pf.frame.axes);
    Rays rays;
    for (std::size_t i = 0; i < 2000; ++i) {
      const Vec3<double> o = far + Vec3<double>{u(rng), u(rng), u(rng)} * 2.0;
      const Sphere& target = d.spheres[i % d.spheres.size()];
      // Towards the sphere's centre, a little off it: most rays hit their target.
      rays.add(o, target.center + Vec3<double>{u(rng), u(rng), u(rng)} * 0.3 - o);
    }
    const Results r = trace(scene, rays, 16);
    std::size_t same_as_double = 0, hits = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
      // The ray as the API was given it, into the prepared frame by the documented rule.
      const Vec3<double> ow{rays.org[3 * i], rays.org[3 * i + 1], rays.org[3 * i + 2]};
      const Vec3<double> dw{rays.dir[3 * i], rays.dir[3 * i + 1], rays.dir[3 * i + 2]};
      const Vec3<double> rel = pd.frame.point(ow), dir = pd.frame.direction(dw);
      const auto ref_d = reference::closest_hit(pd, rel, dir);
      same_as_double += r.id[i] == ref_d.id;
      hits += r.id[i] >= 0;
      if (p == Precision::exact) {
        const auto ref = reference::closest_hit(pf, Vec3<float>::from(rel), Vec3<float>::from(dir));
        ASSERT_EQ(r.id[i], ref.id) << "ray " << i;
        if (ref.id >= 0) {
          ASSERT_TRUE(same_bits(r.t[i], ref.t)) << "ray " << i;
        }
      } else {
        ASSERT_EQ(r.id[i], ref_d.id) << "ray " << i;
        if (ref_d.id >= 0) {
          ASSERT_TRUE(same_bits(r.t[i], float(ref_d.t))) << "ray " << i;
        }
      }
    }
    EXPECT_GT(hits, rays.size() * 8 / 10);
    EXPECT_EQ(same_as_double, rays.size());
    // Normals come back in world space: the sphere's, at the world-space hit point.
    double worst = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
      if (r.id[i] < 0 || r.id[i] >= int(d.spheres.size())) continue;
      const Vec3<double> o{rays.org[3 * i], rays.org[3 * i + 1], rays.org[3 * i + 2]};
      const Vec3<double> dir{rays.dir[3 * i], rays.dir[3 * i + 1], rays.dir[3 * i + 2]};
      const Vec3<double> n = normalize(o + dir * double(r.t[i]) - d.spheres[r.id[i]].center);
      const Vec3<double> ng{r.ng[3 * i], r.ng[3 * i + 1], r.ng[3 * i + 2]};
      worst = std::max(worst, length(ng - n));
    }
    EXPECT_LT(worst, 1e-3);
  }
  // The trap the API closes: world-space origins handed to the prepared frame as they are.
  const auto pf = prepare<float>(d);
  std::size_t wrong = 0;
  for (int i = 0; i < 100; ++i) {
    const Vec3<double> o = far + Vec3<double>{u(rng), u(rng), u(rng)};
    const Vec3<double> dir = normalize(d.spheres[i % 20].center - o);
    const auto right = reference::closest_hit(pf, Vec3<float>::from(pf.frame.point(o)),
                                              Vec3<float>::from(pf.frame.direction(dir)));
    const auto naive = reference::closest_hit(pf, Vec3<float>::from(o), Vec3<float>::from(dir));
    wrong += naive.id != right.id;
  }
  EXPECT_GT(wrong, 90);
}

// Camera rays from camera_ray() through intersect hit what primary_hits() reports, which is
// what lancer's primary mode computes (render_primary_with_ids): bit for bit where the camera
// looks along -z with y up (both frames are then the world's axes at the eye).
TEST(Api, CameraRaysHitWhatPrimaryModeHits) {
  for (const char* file :
       {"scenes/lorenzi-reflections.json", "scenes/many-spheres.json", "scenes/glass-tir.json"}) {
    SCOPED_TRACE(file);
    const Scene desc = load_scene(testing::source_path(file));
    const api::Scene scene = api::Scene::from_description(desc, with(Precision::exact));
    const api::PrimaryHits ph = scene.primary_hits();
    RenderOptions ro;
    ro.precision = Precision::exact;
    ro.threads = 1;
    const PrimaryResult lancer_hits = render_primary_with_ids(desc, ro);
    ASSERT_EQ(ph.t.size(), lancer_hits.t.size());
    for (std::size_t p = 0; p < ph.t.size(); ++p) {
      ASSERT_TRUE(same_bits(ph.t[p], lancer_hits.t[p])) << "pixel " << p;
      ASSERT_EQ(ph.id[p], lancer_hits.id[p]) << "pixel " << p;
    }
    ASSERT_EQ(scene.info().supersample, 1);
    Rays rays;
    for (int j = 0; j < ph.ny; ++j)
      for (int i = 0; i < ph.nx; ++i) {
        float o[3], dir[3];
        scene.camera_ray(i, j, 0, 0, o, dir);
        rays.org.insert(rays.org.end(), o, o + 3);
        rays.dir.insert(rays.dir.end(), dir, dir + 3);
        rays.tfar.push_back(kInf);
        rays.valid.push_back(-1);
      }
    const Results r = trace(scene, rays, 16);
    std::size_t differ = 0, other_object = 0;
    double worst_t = 0;
    for (std::size_t p = 0; p < rays.size(); ++p) {
      differ += r.id[p] != ph.id[p] || !same_bits(r.t[p], ph.t[p]);
      other_object += r.id[p] != ph.id[p];
      if (r.id[p] >= 0 && r.id[p] == ph.id[p])
        worst_t = std::max(worst_t, double(std::fabs(r.t[p] - ph.t[p]) / ph.t[p]));
    }
    if (prepare<float>(desc).frame.axes) {
      // The render's frame keeps the world's axes (a camera looking along -z) and is the
      // queries' too: the round trip through world space is exact.
      EXPECT_EQ(differ, 0u);
    } else {
      // A turned camera: the world-space float ray is the frame's, turned and rounded, then
      // traced in the queries' frame (the world's axes at the eye): the same objects but where
      // that moves a ray across an edge, t within each frame's own rounding.
      EXPECT_LE(other_object, rays.size() / 1000) << other_object << " of " << rays.size();
      EXPECT_LT(worst_t, 5e-5);
      std::printf("%s: %zu of %zu camera rays hit another object, t within %.2g\n", file,
                  other_object, rays.size(), worst_t);
    }
  }
}

// render_rows into a caller's buffer, in bands, with a row stride: lancer::render's bits.
TEST(Api, RenderRowsGivesRendersBits) {
  for (const std::string& file : testing::shipped_scenes()) {
    const Scene desc = load_scene(file);
    for (Options opt : {with(Precision::exact), with(Precision::dbl), with(Precision::exact, 1)}) {
      SCOPED_TRACE(::testing::Message()
                   << file << " " << to_string(opt.precision) << " width " << opt.width);
      opt.threads = 2;
      const api::Scene scene = api::Scene::from_description(desc, opt);
      RenderOptions ro;
      ro.precision = opt.precision;
      ro.width = opt.width;
      ro.threads = 1;
      const RenderResult ref = render(desc, ro);
      const int nx = desc.camera.nx, ny = desc.camera.ny;
      const std::size_t stride = 3 * std::size_t(nx) + 5;
      std::vector<float> buf(stride * ny, -7.0f);
      const int cuts[] = {0, ny / 3, ny / 3 + 1, ny};
      api::RenderStats total;
      for (int c = 0; c < 3; ++c) {
        const api::RenderStats st =
            scene.render_rows(cuts[c], cuts[c + 1], buf.data() + cuts[c] * stride, stride);
        total.camera += st.camera, total.shadow += st.shadow, total.reflected += st.reflected;
      }
      std::size_t differ = 0, padding = 0;
      for (int j = 0; j < ny; ++j) {
        for (int x = 0; x < 3 * nx; ++x)
          differ += !same_bits(buf[j * stride + x], ref.image.rgb[(std::size_t(j) * nx) * 3 + x]);
        for (std::size_t x = 3 * nx; x < stride; ++x) padding += buf[j * stride + x] != -7.0f;
      }
      EXPECT_EQ(differ, 0u);
      EXPECT_EQ(padding, 0u) << "render_rows wrote past a row";
      EXPECT_EQ(total.camera, ref.rays.camera);
      EXPECT_EQ(total.shadow, ref.rays.shadow);
      EXPECT_EQ(total.reflected, ref.rays.reflected);
    }
  }
}

TEST(Api, ReportsWhatItChose) {
  const api::Scene scene =
      api::Scene::load(testing::source_path("scenes/lorenzi-reflections.json"), Options{});
  const api::Info& in = scene.info();
  EXPECT_EQ(in.precision, Precision::exact);  // automatic, inside float's envelope
  EXPECT_FALSE(in.precision_reason.empty());
  EXPECT_EQ(in.width, packet::supported_widths(Precision::exact).front());
  EXPECT_EQ(in.isa, packet::isa_name(in.width, Precision::exact));
  EXPECT_EQ(in.objects, 4);
  EXPECT_EQ(in.nx, 600);
  EXPECT_STRNE(api::version(), "");
}

TEST(Api, BadInputIsAnInputErrorNamingThePlace) {
  const std::string good = testing::source_path("scenes/lorenzi-shadows.json");
  EXPECT_EQ(error_of([] { api::Scene::load("/nonexistent/s.json"); }),
            "/nonexistent/s.json: cannot open scene file");
  Options bad_width;
  bad_width.width = 3;
  EXPECT_NE(error_of([&] { api::Scene::load(good, bad_width); }).find("width: "),
            std::string::npos);
  Options bad_threads;
  bad_threads.threads = -1;
  EXPECT_EQ(error_of([&] { api::Scene::load(good, bad_threads); }),
            "threads: must be from 0 (all cores) to 4096, not -1 (docs/limits.md)");

  Scene d = load_scene(good);
  d.name = "code.json";
  d.spheres.at(1).radius = -1;
  EXPECT_EQ(error_of([&] { api::Scene::from_description(d); }),
            "code.json: objects[1].radius: must be > 0");
  d = load_scene(good);
  d.name = "code.json";
  d.planes.at(0).material = 99;
  EXPECT_EQ(error_of([&] { api::Scene::from_description(d); }),
            "code.json: objects[" + std::to_string(d.spheres.size()) +
                "].material: no material 99 (" + std::to_string(d.materials.size()) +
                " described)");
  d = load_scene(good);
  d.name = "code.json";
  d.camera.distance = std::nan("");
  EXPECT_NE(error_of([&] { api::Scene::from_description(d); }).find("code.json: camera.distance"),
            std::string::npos);

  const api::Scene scene = api::Scene::load(good, with(Precision::exact));
  api::Ray4 r{};
  for (int k = 0; k < 4; ++k) r.dir_z[k] = -1, r.tfar[k] = kInf;
  api::Hit4 h;
  r.dir_z[2] = -2;
  EXPECT_EQ(error_of([&] { scene.intersect(nullptr, r, h); }),
            "intersect: lane 2: dir must be unit length, |dir|^2 = 4.000000");
  const int valid[4] = {-1, -1, 0, -1};
  EXPECT_EQ(error_of([&] { scene.intersect(valid, r, h); }), "(no error)");  // lane 2 inactive
  // An error in the last lane, on a scene whose queries run one lane at a time (16 chunks):
  // every lane is checked before any is traced, so none is written.
  const api::Scene one_lane = api::Scene::load(good, with(Precision::exact, 1));
  api::Ray16 r16{};
  api::Hit16 untouched;
  for (int k = 0; k < 16; ++k) r16.dir_z[k] = -1, r16.tfar[k] = kInf, untouched.id[k] = 42;
  r16.tfar[15] = std::nanf("");
  EXPECT_EQ(error_of([&] { one_lane.intersect(nullptr, r16, untouched); }),
            "intersect: lane 15: tfar is NaN");
  for (int k = 0; k < 16; ++k) EXPECT_EQ(untouched.id[k], 42) << "lane " << k;
  r.dir_z[2] = -1;
  r.org_x[1] = kInf;
  int occ[4];
  EXPECT_EQ(error_of([&] { scene.occluded(nullptr, r, occ); }),
            "occluded: lane 1: org must be finite");
  r.org_x[1] = 0;
  r.tfar[3] = std::nanf("");
  EXPECT_EQ(error_of([&] { scene.occluded(nullptr, r, occ); }), "occluded: lane 3: tfar is NaN");

  std::vector<float> buf(3 * 300 * 200);
  EXPECT_EQ(error_of([&] { scene.render_rows(0, 201, buf.data(), 3 * 300); }),
            "render_rows: rows [0, 201) outside [0, 200)");
  EXPECT_EQ(error_of([&] { scene.render_rows(0, 1, buf.data(), 100); }),
            "render_rows: row_stride 100 is below 3 x nx = 900 floats");
  float o[3], dir[3];
  EXPECT_EQ(error_of([&] { scene.camera_ray(300, 0, 0, 0, o, dir); }),
            "camera_ray: pixel (300, 0) outside the 300x200 image");
}

// A description built in code is the same scene as the file it came from: same image.
TEST(Api, DescriptionInCodeIsTheFilesScene) {
  const std::string file = testing::source_path("scenes/lorenzi-reflections.json");
  const api::Scene a = api::Scene::load(file, with(Precision::exact));
  const api::Scene b = api::Scene::from_description(load_scene(file), with(Precision::exact));
  const int nx = a.info().nx, ny = a.info().ny;
  std::vector<float> ia(3 * std::size_t(nx) * ny), ib(ia.size());
  a.render_rows(0, ny, ia.data(), 3 * nx);
  b.render_rows(0, ny, ib.data(), 3 * nx);
  EXPECT_EQ(std::memcmp(ia.data(), ib.data(), ia.size() * sizeof(float)), 0);
}

}  // namespace
}  // namespace lancer
