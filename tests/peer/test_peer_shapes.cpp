// The Embree peer on triangles, meshes and cylinders: every setup lancer bench tries must hit
// what lancer's reference hits (object ids spheres, planes, then shapes), ray by ray, and trace
// what lancer's primary and full renders trace; round linear curves, a capsule standing in for a
// capped cylinder, must agree wherever lancer hits a cylinder's side; lancer bench runs the peer
// on shape scenes and names the fastest setup.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "lancer/error.hpp"
#include "lancer/formulas.hpp"
#include "lancer/generate.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/peer.hpp"
#include "lancer/prepared.hpp"
#include "lancer/reference.hpp"
#include "lancer/render.hpp"
#include "lancer/scene.hpp"
#include "lancer/shapes.hpp"
#include "peer_compare.hpp"

namespace lancer {
namespace {

using testing::Agreement;
using testing::compare_camera_rays;

// lancer's ray enters a capped cylinder through its side (not an end disc, nor an open
// cylinder's inside): there the capsule of a round linear curve has the same surface in front of
// the ray (the infinite tube is convex and holds the capsule, so a ray entering the tube through
// the side met neither of its half-spheres before).
bool enters_cylinder_side(const PreparedScene<float>& s, int id, const Vec3<float>& o,
                          const Vec3<float>& d, float t) {
  if (id < s.num_spheres + s.num_planes) return false;
  const PreparedShapes<float>& sh = *s.shapes;
  for (std::size_t k = 0; k < sh.cyl_object.size(); ++k) {
    if (sh.cyl_object[k] != id) continue;
    const Vec3<float> a = sh.cyl_axis[k], q = along(o, d, t) - sh.cyl_base[k];
    const float z = dot(q, a);
    const float h = sh.cyl_h[k], r = std::sqrt(sh.cyl_r2[k]);
    // Away from the rims by a thousandth of the radius: a disc hit there is no side hit.
    return sh.cyl_caps[k] && z > 1e-3f * r && z < h - 1e-3f * r && dot(q - a * z, d) < 0.0f;
  }
  return false;
}

std::string temp_dir() {
  const std::string dir =
      (std::filesystem::temp_directory_path() / ("lancer-peer-shapes-" + std::to_string(getpid())))
          .string();
  std::filesystem::create_directories(dir);
  return dir;
}

// A generated scene: `spheres` spheres (and `cylinders` of them cylinders), a sphere mesh of
// about `triangles` triangles beside it (none for 0) and the ground plane.
Scene generated(long long spheres, long long cylinders, long long triangles, int nx, int ny) {
  const std::string dir = temp_dir();
  generate::Options g;
  g.spheres = spheres;
  g.cylinders = cylinders;
  g.nx = nx, g.ny = ny;
  if (triangles > 0) {
    std::ofstream(dir + "/mesh.ply", std::ios::binary) << generate::sphere_ply(triangles);
    g.mesh_file = "mesh.ply";
  }
  std::ofstream(dir + "/scene.json") << generate::scene_json(g);
  Scene scene = load_scene(dir + "/scene.json");
  std::filesystem::remove_all(dir);
  return scene;
}

std::vector<int> widths() { return peer::embree_widths({1, 4, 8, 16}); }

// Per pixel, the peer's primary() against lancer's: finite alike and the same sum of t within
// `rel`; returns the share of pixels that differ.
double primary_differs(const Scene& scene, const peer::EmbreeScene& embree, int width, float rel) {
  RenderOptions ro;
  ro.width = 1;
  ro.threads = 1;
  const PrimaryResult l = render_primary(scene, ro);
  const PrimaryResult e = embree.primary(width, 2);
  EXPECT_EQ(e.t.size(), l.t.size());
  EXPECT_EQ(e.rays, l.rays);
  std::size_t differ = 0;
  for (std::size_t k = 0; k < l.t.size() && k < e.t.size(); ++k)
    differ += std::isfinite(l.t[k]) != std::isfinite(e.t[k]) ||
              (std::isfinite(l.t[k]) && std::abs(e.t[k] - l.t[k]) > rel * l.t[k]);
  return double(differ) / double(l.t.size());
}

// Tolerances: fewer than 1 ray in 1000 may hit or miss otherwise, or hit another object (at
// silhouettes and shared edges, where Embree's tests and lancer's round differently), and t may
// differ by 1e-4 of itself (float tests of the same surface: measured below 1e-5).
constexpr double kShare = 1e-3, kRelT = 1e-4;

void expect_agrees(const Agreement& a) {
  ASSERT_GT(a.rays, 0u);
  EXPECT_LT(double(a.hit_miss) / a.rays, kShare) << a.hit_miss << " of " << a.rays;
  EXPECT_LT(double(a.other_object) / a.rays, kShare) << a.other_object << " of " << a.rays;
  EXPECT_LT(a.max_rel_t, kRelT);
}

TEST(EmbreePeerShapes, SetupsOfShapeScenesSpanBuildsPacketsAndCylinderModels) {
  const Scene mesh = generated(0, 0, 500, 32, 24);
  const Scene cyl = load_scene(std::string(LANCER_SOURCE_DIR) + "/scenes/prims/cylinders.json");
  const std::vector<peer::EmbreeConfig> m = peer::embree_setups({&mesh});
  const std::vector<peer::EmbreeConfig> c = peer::embree_setups({&mesh, &cyl});
  EXPECT_EQ(m.size(), 12u);
  EXPECT_EQ(c.size(), 24u);
  std::vector<std::string> names;
  for (const peer::EmbreeConfig& how : c) names.push_back(how.name());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(std::unique(names.begin(), names.end()), names.end()) << "two setups, one name";
  EXPECT_EQ(m[0].name(), "triangles, build medium");
  EXPECT_EQ(m[8].name(), "triangles, build medium, robust, 1M streams");
  EXPECT_EQ(m[11].name(), "triangles, build high, robust, 1M streams");
  EXPECT_EQ(c[23].name(), "round curves, build high, robust, 1M streams");
  EXPECT_TRUE(m[1].same_build(m[0]));
  EXPECT_FALSE(m[3].same_build(m[0]));
}

// Sets LANCER_EMBREE_SETUP for a scope.
struct SetupEnv {
  explicit SetupEnv(const char* v) { ::setenv("LANCER_EMBREE_SETUP", v, 1); }
  ~SetupEnv() { ::unsetenv("LANCER_EMBREE_SETUP"); }
};

TEST(EmbreePeerShapes, SetupWordsNameTheRobustFlagAndCurves) {
  const SetupEnv env("robust,curves,streams");
  const peer::EmbreeConfig c = peer::embree_config_from_env();
  EXPECT_TRUE(c.robust && c.curves && c.streams && !c.high_quality);
  const Scene cyl = load_scene(std::string(LANCER_SOURCE_DIR) + "/scenes/prims/cylinders.json");
  const std::vector<peer::EmbreeConfig> only = peer::embree_setups({&cyl});
  ASSERT_EQ(only.size(), 1u);
  EXPECT_EQ(only[0].name(), "round curves, build medium, robust, 1M streams");
  const SetupEnv bad("robust,wobbly");
  EXPECT_THROW(peer::embree_config_from_env(), InputError);
}

// Setups that trace alike share one Embree scene; one that builds otherwise cannot.
TEST(EmbreePeerShapes, OnlySetupsOfTheSameBuildShareAScene) {
  if (!packet::kernels_for(4)) GTEST_SKIP() << "no packet kernels on this machine";
  if (!peer::embree_available()) GTEST_SKIP() << "built without Embree";
  const Scene scene = generated(0, 0, 500, 32, 24);
  peer::EmbreeConfig rows, squares, high;
  squares.tiles = true;
  high.high_quality = true;
  const peer::EmbreeScene built(scene, peer::PlaneMode::user, "", rows);
  const peer::EmbreeScene shared(built, squares);
  EXPECT_EQ(shared.config().name(), squares.name());
  EXPECT_EQ(shared.build_seconds(), built.build_seconds());
  EXPECT_EQ(shared.primary(4, 1).rays, built.primary(4, 1).rays);
  EXPECT_THROW(peer::EmbreeScene(built, high), std::logic_error);
}

TEST(EmbreePeerShapes, MeshCameraRaysHitAsLancerInEverySetup) {
  if (!peer::embree_available()) GTEST_SKIP() << "built without Embree";
  const Scene scene = generated(0, 0, 1000, 96, 64);
  ASSERT_GT(scene.triangles(), 999u);
  for (const peer::EmbreeConfig& how : peer::embree_setups({&scene})) {
    const peer::EmbreeScene embree(scene, peer::PlaneMode::user, "", how);
    for (int w : widths()) {
      SCOPED_TRACE(how.name() + ", width " + std::to_string(w));
      const Agreement a = compare_camera_rays(scene, embree, w);
      expect_agrees(a);
      std::printf("  mesh %-45s w=%-2d %zu rays, hit/miss %zu, object %zu, max |dt|/t %.2g\n",
                  how.name().c_str(), w, a.rays, a.hit_miss, a.other_object, a.max_rel_t);
      EXPECT_LT(primary_differs(scene, embree, w, 1e-4f), kShare);
    }
  }
}

// Spheres, planes, cylinders and a mesh in one scene: every geometry's ids map back to lancer's
// object ids.
TEST(EmbreePeerShapes, MixedSceneObjectIdsMapBackToLancers) {
  if (!peer::embree_available()) GTEST_SKIP() << "built without Embree";
  const Scene scene = generated(300, 40, 2000, 96, 64);
  ASSERT_FALSE(scene.spheres.empty());
  ASSERT_FALSE(scene.planes.empty());
  ASSERT_TRUE(std::any_of(scene.shapes.begin(), scene.shapes.end(),
                          [](const Shape& sh) { return sh.kind == Shape::Kind::cylinder; }));
  ASSERT_GT(scene.triangles(), 1999u);
  for (const peer::EmbreeConfig& how : peer::embree_setups({&scene})) {
    if (how.curves) continue;  // capsules: checked on cylinder sides below
    SCOPED_TRACE(how.name());
    const peer::EmbreeScene embree(scene, peer::PlaneMode::user, "", how);
    expect_agrees(compare_camera_rays(scene, embree, widths().back()));  // the widest here
  }
}

TEST(EmbreePeerShapes, CylindersAsUserGeometryHitAsLancerAndCurvesOnTheSides) {
  if (!peer::embree_available()) GTEST_SKIP() << "built without Embree";
  Scene scene = load_scene(std::string(LANCER_SOURCE_DIR) + "/scenes/prims/cylinders.json");
  scene.camera.nx = 240, scene.camera.ny = 160;  // the same view, a quarter of the rays
  for (const peer::EmbreeConfig& how : peer::embree_setups({&scene})) {
    const peer::EmbreeScene embree(scene, peer::PlaneMode::user, "", how);
    for (int w : widths()) {
      SCOPED_TRACE(how.name() + ", width " + std::to_string(w));
      const Agreement all = compare_camera_rays(scene, embree, w);
      const Agreement sides = compare_camera_rays(scene, embree, w, &enters_cylinder_side);
      std::printf(
          "  cylinders %-45s w=%-2d all %zu rays: hit/miss %zu, object %zu, max |dt|/t %.2g; "
          "sides %zu rays: %zu, %zu, %.2g\n",
          how.name().c_str(), w, all.rays, all.hit_miss, all.other_object, all.max_rel_t,
          sides.rays, sides.hit_miss, sides.other_object, sides.max_rel_t);
      if (how.curves) {
        // Where lancer's ray enters a cylinder's side, the capsule is hit at the same place
        // unless another capsule's half-sphere, sticking out past its end, stands in front.
        ASSERT_GT(sides.rays, 0u);
        EXPECT_EQ(sides.hit_miss, 0u);
        EXPECT_EQ(sides.other_object, sides.other_cylinder);
        EXPECT_LT(double(sides.other_object) / sides.rays, 0.02);
        EXPECT_LT(sides.max_rel_t, kRelT);
        // Elsewhere the half-spheres differ from the discs: they are not the same surface.
        EXPECT_GT(all.hit_miss + all.other_object, 0u);
        EXPECT_GT(all.max_rel_t, kRelT);
        continue;
      }
      expect_agrees(sides);
      expect_agrees(all);
      EXPECT_LT(primary_differs(scene, embree, w, 1e-4f), kShare);
    }
  }
}

TEST(EmbreePeerShapes, FullRayTrafficCountsLancersRaysOnAMesh) {
  if (!peer::embree_available()) GTEST_SKIP() << "built without Embree";
  const Scene scene = generated(0, 0, 1000, 96, 64);
  const peer::EmbreeScene embree(scene);
  RenderOptions ro;
  ro.width = 1;
  ro.threads = 1;
  const RayCounts l = render(scene, ro).rays;
  ASSERT_GT(l.shadow, 0u);
  for (int w : widths()) {
    const RayCounts e = embree.trace_all(w, 2).rays;
    EXPECT_EQ(e.camera, l.camera);
    const double tol = 1e-3 * double(l.total()) + 1;
    EXPECT_NEAR(double(e.shadow), double(l.shadow), tol) << "width " << w;
    EXPECT_NEAR(double(e.reflected), double(l.reflected), tol) << "width " << w;
  }
}

int run(const std::string& args, std::string* out) {
  const std::string cmd = std::string(LANCER_CLI) + " " + args + " 2>/dev/null";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return -1;
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) out->append(buf, n);
  const int st = pclose(p);
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

// Regression: the peer refused every scene with a triangle, mesh or cylinder (exit 2).
TEST(EmbreePeerShapes, BenchRunsThePeerOnShapeScenesAndNamesTheFastestSetup) {
  if (!peer::embree_available()) GTEST_SKIP() << "built without Embree";
  std::string out;
  ASSERT_EQ(run("bench --peer embree --mode primary --width 1 --repeat 1 --warmup 0 --json "
                "--resolution 48x32 " +
                    std::string(LANCER_SOURCE_DIR) + "/scenes/prims/cylinders.json",
                &out),
            0);
  const nlohmann::json j = nlohmann::json::parse(out);
  int peer_rows = 0;
  for (const auto& r : j["results"])
    if (r["engine"] == "embree") {
      ++peer_rows;
      const std::string name = r["config"];
      EXPECT_TRUE(name.find("user cylinders") == 0 || name.find("round curves") == 0) << name;
    }
  EXPECT_EQ(peer_rows, 1);
  // Width 1: no square packets; rows and streams of four builds, two cylinder models.
  EXPECT_EQ(j["peer_setups"].size(), 16u);
}

}  // namespace
}  // namespace lancer
