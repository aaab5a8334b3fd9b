// The incoherent ray sets of bench's ao and diffuse modes (include/lancer/ray_sets.hpp): how
// they are made, that every width of the library API answers them as the reference does, that
// the Embree peer agrees within its tolerance, and the CLI's modes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>

#include "lancer/generate.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/peer.hpp"
#include "lancer/ray_sets.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

using json = nlohmann::json;
using testing::cli;
using testing::run_command;

// A scene at a small resolution (the rays' count, not their kind, is what a test can spare).
api::Scene small(Scene s, int nx = 120, int ny = 80) {
  s.camera.nx = nx, s.camera.ny = ny;
  s.supersample = 1;
  api::Options o;
  o.precision = Precision::exact;
  o.threads = 1;
  return api::Scene::from_description(std::move(s), o);
}

Scene cloud(long long spheres) {
  generate::Options g;
  g.spheres = spheres;
  g.seed = 1;
  return parse_scene(generate::scene_json(g), "cloud");
}

TEST(RaySets, GeneratorFollowsTheStandard) {
  // The C++ standard fixes mt19937_64's 10000th output for the default seed: the sets rest on it.
  std::mt19937_64 rng;
  rng.discard(9999);
  EXPECT_EQ(rng(), 9981545732273789042ull);
  std::mt19937_64 a(7);
  const double u = rays::unit_uniform(a);
  std::mt19937_64 b(7);
  EXPECT_EQ(u, double(b() >> 11) * 0x1p-53);
  EXPECT_GE(u, 0.0);
  EXPECT_LT(u, 1.0);
}

// The first two directions of seed 1 about one normal, as this test first computed them: on any
// platform and compiler they must come out the same, bit for bit (only exact IEEE operations).
TEST(RaySets, SameDirectionsEverywhere) {
  std::mt19937_64 rng(1);
  const Vec3<double> n = normalize(Vec3<double>{1, 2, -3});
  const Vec3<double> a = rays::cosine_direction(rng, n), b = rays::cosine_direction(rng, n);
  EXPECT_EQ(a.x, -0x1.8f8577bc5cf4fp-4);
  EXPECT_EQ(a.y, 0x1.ea80b2bf2cb9cp-1);
  EXPECT_EQ(a.z, 0x1.1418362ad1298p-2);
  EXPECT_EQ(b.x, -0x1.780cf2236b17p-4);
  EXPECT_EQ(b.y, -0x1.a3c3e6d651eccp-2);
  EXPECT_EQ(b.z, -0x1.d0a202e2b71c8p-1);
}

TEST(RaySets, CosineWeightedAboutTheNormal) {
  std::mt19937_64 rng(3);
  const Vec3<double> normals[] = {{0, 0, 1},
                                  {0, 0, -1},
                                  {1, 0, 0},
                                  {0, -1, 0},
                                  normalize(Vec3<double>{1, 2, -3}),
                                  normalize(Vec3<double>{-0.2, 0.1, -1e-9})};
  for (const Vec3<double>& n : normals) {
    const int count = 200000;
    double sum = 0;
    int below_half = 0;
    for (int k = 0; k < count; ++k) {
      const Vec3<double> w = rays::cosine_direction(rng, n);
      ASSERT_NEAR(dot(w, w), 1.0, 1e-12);
      const double c = dot(w, n);
      ASSERT_GE(c, 0.0);
      sum += c;
      below_half += c < 0.5;
    }
    // Cosine-weighted: E[cos] = 2/3 (sd of the mean 0.0005), P(cos < 1/2) = 1/4 (sd 0.001).
    EXPECT_NEAR(sum / count, 2.0 / 3.0, 0.003) << n.x << " " << n.y << " " << n.z;
    EXPECT_NEAR(double(below_half) / count, 0.25, 0.005);
  }
}

TEST(RaySets, Extent) {
  Scene s;
  s.spheres.push_back({{0, 0, 0}, 1});
  s.spheres.push_back({{4, 0, 0}, 2});
  s.planes.push_back({});
  // Box (-1..6, -2..2, -2..2): the plane is unbounded and left out.
  EXPECT_DOUBLE_EQ(rays::scene_extent(s), std::sqrt(49.0 + 16 + 16));
  Scene planes;
  planes.camera.position = {0, 3, 4};
  planes.planes.push_back({});
  EXPECT_DOUBLE_EQ(rays::scene_extent(planes), 5.0);
}

TEST(RaySets, MadeAsStated) {
  const api::Scene scene =
      small(load_scene(std::string(LANCER_SOURCE_DIR) + "/scenes/lorenzi-reflections.json"));
  const double extent = rays::scene_extent(scene.description());
  const rays::RaySet ao = rays::make_set(scene, rays::Kind::ao);
  EXPECT_EQ(ao.tfar, float(0.05 * extent));
  EXPECT_EQ(ao.offset, 1e-4 * extent);
  EXPECT_EQ(ao.size(), 4 * ao.camera_hits);
  EXPECT_GT(ao.camera_hits, 0u);
  EXPECT_LT(ao.camera_hits, std::size_t(120 * 80));  // some sky
  const rays::RaySet diffuse = rays::make_set(scene, rays::Kind::diffuse);
  EXPECT_TRUE(std::isinf(diffuse.tfar));
  // The same seed, the same rays, whatever the kind; another seed, others.
  ASSERT_EQ(diffuse.size(), ao.size());
  EXPECT_EQ(0, std::memcmp(ao.dx.data(), diffuse.dx.data(), ao.size() * sizeof(float)));
  EXPECT_EQ(0, std::memcmp(ao.oz.data(), diffuse.oz.data(), ao.size() * sizeof(float)));
  rays::SetOptions other;
  other.seed = 2;
  const rays::RaySet ao2 = rays::make_set(scene, rays::Kind::ao, other);
  EXPECT_EQ(ao2.ox, ao.ox);  // the origins come from the camera hits alone
  EXPECT_NE(ao2.dx, ao.dx);
  // Each hit's rays leave into the hemisphere of its normal turned to the camera: back along the
  // camera ray from the origin is that side too, so the ray and the way back to the camera agree.
  std::size_t k = 0;
  for (int j = 0; j < 80; ++j)
    for (int i = 0; i < 120; ++i) {
      float o[3], d[3];
      scene.camera_ray(i, j, 0, 0, o, d);
      api::Ray1 r;
      api::Hit1 h;
      r.org_x[0] = o[0], r.org_y[0] = o[1], r.org_z[0] = o[2];
      r.dir_x[0] = d[0], r.dir_y[0] = d[1], r.dir_z[0] = d[2];
      r.tnear[0] = 0, r.tfar[0] = INFINITY, r.mask[0] = api::kAllObjects;
      scene.intersect(nullptr, r, h);
      if (h.id[0] < 0) continue;
      Vec3<double> n{h.ng_x[0], h.ng_y[0], h.ng_z[0]};
      if (dot(n, Vec3<double>{d[0], d[1], d[2]}) > 0) n = -n;
      for (int q = 0; q < 4; ++q, ++k) {
        ASSERT_LT(k, ao.size());
        const Vec3<double> w{ao.dx[k], ao.dy[k], ao.dz[k]};
        EXPECT_NEAR(dot(w, w), 1.0, 1e-6);
        EXPECT_GT(dot(w, n), -1e-6) << "ray " << k;
        // The origin: the hit point moved `offset` along the normal.
        const Vec3<double> p{o[0] + double(d[0]) * h.t[0], o[1] + double(d[1]) * h.t[0],
                             o[2] + double(d[2]) * h.t[0]};
        const Vec3<double> from{ao.ox[k], ao.oy[k], ao.oz[k]};
        EXPECT_NEAR(dot(from - p, n), ao.offset, 1e-5 * extent);
      }
    }
  EXPECT_EQ(k, ao.size());
}

// Every width's answers equal the reference's, bit for bit, and the sets are not trivial.
void expect_widths_agree(const api::Scene& scene, const std::string& name) {
  for (rays::Kind kind : {rays::Kind::ao, rays::Kind::diffuse}) {
    const rays::RaySet set = rays::make_set(scene, kind);
    rays::Answers ref;
    rays::ApiPackets(set, 1).trace(scene, 1, &ref);
    std::size_t yes = 0;
    for (std::size_t k = 0; k < set.size(); ++k)
      yes += set.occlusion() ? ref.occluded[k] != 0 : ref.id[k] >= 0;
    if (kind == rays::Kind::diffuse) {
      EXPECT_GT(yes, 0u) << name << ": no diffuse ray hits";
    }
    EXPECT_LT(yes, set.size()) << name << " " << rays::to_string(kind) << ": every ray answered";
    const bool kernels = scene.description().shapes.empty();
    const auto prepared =
        kernels ? rays::KernelPackets::prepare(scene.description(), Precision::exact) : nullptr;
    for (int width : testing::packet_widths()) {
      rays::Answers got;
      rays::ApiPackets(set, width).trace(scene, width == 8 ? 2 : 1, &got);
      const rays::Agreement a = rays::compare(set, ref, got, 0);
      EXPECT_EQ(a.differ, 0u) << name << " " << rays::to_string(kind) << " width " << width;
      if (!kernels) continue;
      // The kernels without the API: the same answers from the same floats.
      rays::Answers direct;
      rays::KernelPackets(prepared, set, width).trace(width == 4 ? 2 : 1, &direct);
      EXPECT_EQ(rays::compare(set, ref, direct, 0).differ, 0u)
          << name << " " << rays::to_string(kind) << " kernels, width " << width;
    }
  }
}

TEST(RaySets, EveryWidthAgreesOnTheCourseScenes) {
  for (const auto& entry :
       std::filesystem::directory_iterator(std::string(LANCER_SOURCE_DIR) + "/scenes")) {
    if (entry.path().extension() != ".json") continue;
    SCOPED_TRACE(entry.path().string());
    expect_widths_agree(small(load_scene(entry.path().string())), entry.path().filename());
  }
}

TEST(RaySets, EveryWidthAgreesOnACloud) {
  expect_widths_agree(small(cloud(1024), 150, 100), "cloud of 1024");
}

TEST(RaySets, OcclusionSeesSomethingInACloud) {
  const api::Scene scene = small(cloud(1024), 150, 100);
  const rays::RaySet set = rays::make_set(scene, rays::Kind::ao);
  rays::Answers ref;
  rays::ApiPackets(set, 16).trace(scene, 1, &ref);
  std::size_t occluded = 0;
  for (int v : ref.occluded) occluded += v != 0;
  EXPECT_GT(occluded, 0u);
  EXPECT_LT(occluded, set.size());
}

TEST(RaySets, EmbreeAgrees) {
  if (!peer::embree_available()) GTEST_SKIP() << "built without Embree";
  for (long long spheres : {0LL, 1024LL}) {
    Scene desc =
        spheres ? cloud(spheres)
                : load_scene(std::string(LANCER_SOURCE_DIR) + "/scenes/lorenzi-reflections.json");
    desc.camera.nx = 120, desc.camera.ny = 80;
    const api::Scene scene = small(desc);
    for (rays::Kind kind : {rays::Kind::ao, rays::Kind::diffuse}) {
      const rays::RaySet set = rays::make_set(scene, kind);
      rays::Answers ref;
      rays::ApiPackets(set, 1).trace(scene, 1, &ref);
      for (bool streams : {false, true}) {
        peer::EmbreeConfig how;
        how.streams = streams;
        const peer::EmbreeScene e(desc, peer::PlaneMode::user, "", how);
        const auto loaded = e.load_rays(set);
        for (int width : {1, 4, 16}) {
          rays::Answers got;
          // Two threads at width 4: the answers do not depend on the split.
          e.trace_rays(*loaded, width, width == 4 ? 2 : 1, &got);
          const rays::Agreement a = rays::compare(set, ref, got, 1e-4);
          // Embree's own sphere test in float: a handful of grazing rays may differ.
          std::printf("embree %s, %lld spheres, width %d%s: %zu of %zu rays differ\n",
                      rays::to_string(kind), spheres, width, streams ? " streams" : "", a.differ,
                      a.rays);
          EXPECT_LE(a.differ, a.rays / 10000) << rays::to_string(kind) << " width " << width;
        }
      }
    }
  }
}

// The narrowest packet width this machine runs in a precision (after LANCER_MAX_WIDTH), 0 if none.
int narrowest_packet(Precision p) {
  int w = 0;
  for (int x : packet::supported_widths(p))
    if (x > 1) w = x;
  return w;
}

TEST(RaySets, BenchModesRunAndNameTheirRows) {
  const std::string scene = std::string(LANCER_SOURCE_DIR) + "/scenes/lorenzi-reflections.json";
  const int w = narrowest_packet(Precision::exact);
  if (w == 0) GTEST_SKIP() << "no packet width on this machine";
  const testing::CommandResult r =
      run_command(cli() + " bench " + scene + " --mode ao,diffuse --width 1," + std::to_string(w) +
                  " --repeat 1 --warmup 0 --resolution 48x32 --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const json j = json::parse(r.out);
  int ao = 0, diffuse = 0;
  for (const json& row : j["results"]) {
    ao += row["mode"] == "ao";
    diffuse += row["mode"] == "diffuse";
    EXPECT_GT(row["rays"].get<double>(), 0);
    EXPECT_GT(row["mrays_per_s"].get<double>(), 0);
  }
  // Widths 1 and w through the API, and width w straight into the kernels.
  EXPECT_EQ(ao, 3);
  EXPECT_EQ(diffuse, 3);
  ASSERT_EQ(j["ray_sets"].size(), 2u);
  EXPECT_EQ(j["ray_sets"][0]["per_hit"], 4);
  ASSERT_EQ(j["agreement"].size(), 6u);
  for (const json& c : j["agreement"]) EXPECT_EQ(c["differ"], 0) << c.dump();
  // The library API reports no structure: none is shown rather than an empty one.
  EXPECT_FALSE(j.contains("structure"));
}

TEST(RaySets, DoubleRowsHeldToDoublesReference) {
  // Packets of 4 through the API and the double kernels of width 4 (AVX2) alone.
  const std::vector<int> widths = packet::supported_widths(Precision::dbl);
  if (std::find(widths.begin(), widths.end(), 4) == widths.end())
    GTEST_SKIP() << "no double packets of 4 on this machine";
  const int w = 4;
  const testing::CommandResult r =
      run_command(cli() + " bench " + std::string(LANCER_SOURCE_DIR) +
                  "/scenes/lorenzi-reflections.json --mode diffuse --precision double --width 1," +
                  std::to_string(w) + " --repeat 1 --warmup 0 --resolution 48x32 --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const json j = json::parse(r.out);
  ASSERT_EQ(j["agreement"].size(), 2u);
  for (const json& c : j["agreement"]) {
    EXPECT_EQ(c["precision"], "double");
    EXPECT_EQ(c["tolerance"], 0.0);
    EXPECT_EQ(c["differ"], 0);
  }
}

TEST(RaySets, AccelIsRefusedForTheApiModes) {
  const testing::CommandResult r =
      run_command(cli() + " bench " + std::string(LANCER_SOURCE_DIR) +
                  "/scenes/lorenzi-reflections.json --mode ao --accel none");
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(r.out.find('\n'), r.out.size() - 1) << r.out;  // one line
  EXPECT_NE(r.out.find("--accel"), std::string::npos);
}

TEST(RaySets, BadModeIsOneLine) {
  const testing::CommandResult r = run_command(cli() + " bench " + std::string(LANCER_SOURCE_DIR) +
                                               "/scenes/lorenzi-reflections.json --mode ambient");
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(r.out, "lancer: --mode: must be primary, full, kernel, ao or diffuse, not 'ambient'\n");
}

}  // namespace
}  // namespace lancer
