// The Embree peer against lancer: the same camera rays must hit and miss alike (a disagreement
// on fewer than 0.1% of them, at silhouettes, where Embree's sphere test and lancer's round
// differently), and its full-render ray traffic must count the rays lancer's render counts.
// Also: the peak kernels and flop counts, and the CLI's --peer / --peak.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "lancer/error.hpp"
#include "lancer/formulas.hpp"
#include "lancer/generate.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/peak.hpp"
#include "lancer/peer.hpp"
#include "lancer/prepared.hpp"
#include "lancer/reference.hpp"
#include "lancer/render.hpp"
#include "lancer/scene.hpp"
#include "peer_compare.hpp"

namespace lancer {
namespace {

std::vector<std::string> scenes() {
  std::vector<std::string> out;
  for (const auto& e :
       std::filesystem::directory_iterator(std::string(LANCER_SOURCE_DIR) + "/scenes"))
    if (e.path().extension() == ".json") out.push_back(e.path().string());
  std::sort(out.begin(), out.end());
  return out;
}

using testing::Agreement;
using testing::compare_camera_rays;

std::vector<int> widths() { return peer::embree_widths({1, 4, 8, 16}); }

TEST(EmbreePeer, CameraRaysHitAndMissAsLancerOnEveryScene) {
  if (!peer::embree_available()) GTEST_SKIP() << "built without Embree";
  for (const peer::PlaneMode mode : {peer::PlaneMode::user, peer::PlaneMode::quad}) {
    for (const std::string& path : scenes()) {
      const Scene scene = load_scene(path);
      const peer::EmbreeScene embree(scene, mode);
      for (int w : widths()) {
        SCOPED_TRACE(path + " width " + std::to_string(w) +
                     (mode == peer::PlaneMode::user ? " user planes" : " quad planes"));
        const Agreement a = compare_camera_rays(scene, embree, w);
        ASSERT_GT(a.rays, 0u);
        EXPECT_LT(double(a.hit_miss) / a.rays, 1e-3) << a.hit_miss << " of " << a.rays;
        EXPECT_LT(double(a.other_object) / a.rays, 1e-3) << a.other_object << " of " << a.rays;
        // Quads stand for planes with float corners kPlaneExtent scene sizes away: where the
        // camera's frame tilts a plane against the axes (glass-tir.json), the corners round off
        // it by an ulp of that distance, and t moves by up to 2e-3 of itself (measured 1.8e-3).
        EXPECT_LT(a.max_rel_t, mode == peer::PlaneMode::quad ? 4e-3 : 1e-3);
        std::printf(
            "  %-40s w=%-2d %s: %zu rays, hit/miss differ %zu, object differs %zu, "
            "max |dt|/t %.2g\n",
            std::filesystem::path(path).filename().c_str(), w,
            mode == peer::PlaneMode::user ? "user" : "quad", a.rays, a.hit_miss, a.other_object,
            a.max_rel_t);
      }
    }
  }
}

TEST(EmbreePeer, PrimaryMatchesRenderPrimaryPerPixel) {
  if (!peer::embree_available()) GTEST_SKIP() << "built without Embree";
  for (const std::string& path : scenes()) {
    SCOPED_TRACE(path);
    const Scene scene = load_scene(path);
    // The peer traces camera, shadow and mirror rays only: no refracted rays to count.
    if (prepare<float>(scene).features.refraction) continue;
    const peer::EmbreeScene embree(scene);
    RenderOptions ro;
    ro.width = 1;
    ro.threads = 1;
    const PrimaryResult l = render_primary(scene, ro);
    for (int w : widths()) {
      for (int threads : {1, 2}) {
        const PrimaryResult e = embree.primary(w, threads);
        ASSERT_EQ(e.t.size(), l.t.size());
        EXPECT_EQ(e.rays, l.rays);
        std::size_t differ = 0;
        for (std::size_t k = 0; k < l.t.size(); ++k)
          differ += std::isfinite(l.t[k]) != std::isfinite(e.t[k]);
        EXPECT_LT(double(differ) / l.t.size(), 1e-3) << differ << " pixels, width " << w;
      }
    }
  }
}

// Every setup the bench can pick (issue 12: Embree at its best) hits what lancer hits, on the
// shipped scenes and on a generated one of 3000 spheres: camera_hits (row packets) object by
// object, and primary() (rows, 4x4 packets or streams) pixel by pixel against lancer's primary.
TEST(EmbreePeer, EverySetupAgreesWithLancer) {
  if (!peer::embree_available()) GTEST_SKIP() << "built without Embree";
  std::vector<peer::EmbreeConfig> setups(6);
  setups[1].user_spheres = true;
  setups[2].high_quality = true;
  setups[3].tiles = true;
  setups[4] = {true, true, true, true, false};
  setups[5].user_spheres = setups[5].streams = true;
  generate::Options g;
  g.spheres = 3000;
  g.nx = 96, g.ny = 64;
  std::vector<Scene> all;
  all.push_back(parse_scene(generate::scene_json(g), "generated.json"));
  for (const std::string& path : scenes()) all.push_back(load_scene(path));
  // Embree's packets as wide as this machine runs lancer's (16 with AVX-512).
  const int wide = peer::embree_widths({1, 4, 8, 16}).back();
  for (const Scene& scene : all) {
    RenderOptions ro;
    ro.width = 1;
    ro.threads = 1;
    const PrimaryResult l = render_primary(scene, ro);
    for (const peer::EmbreeConfig& how : setups) {
      SCOPED_TRACE(scene.name + ": " + how.name());
      const peer::EmbreeScene embree(scene, peer::PlaneMode::user, "", how);
      EXPECT_EQ(embree.config().name(), how.name());
      EXPECT_GT(embree.build_seconds(), 0.0);
      const Agreement a = compare_camera_rays(scene, embree, wide);
      EXPECT_LT(double(a.hit_miss) / a.rays, 1e-3) << a.hit_miss << " of " << a.rays;
      EXPECT_LT(double(a.other_object) / a.rays, 1e-3) << a.other_object << " of " << a.rays;
      EXPECT_LT(a.max_rel_t, 1e-3);
      const PrimaryResult e = embree.primary(wide, 2);
      ASSERT_EQ(e.t.size(), l.t.size());
      EXPECT_EQ(e.rays, l.rays);
      std::size_t differ = 0;
      for (std::size_t k = 0; k < l.t.size(); ++k)
        differ += std::isfinite(l.t[k]) != std::isfinite(e.t[k]) ||
                  (std::isfinite(l.t[k]) && std::abs(e.t[k] - l.t[k]) > 1e-3f * l.t[k]);
      EXPECT_LT(double(differ) / l.t.size(), 1e-3) << differ << " pixels";
    }
  }
}

TEST(EmbreePeer, FullRayTrafficCountsLancersRays) {
  if (!peer::embree_available()) GTEST_SKIP() << "built without Embree";
  for (const std::string& path : scenes()) {
    SCOPED_TRACE(path);
    const Scene scene = load_scene(path);
    // The peer traces camera, shadow and mirror rays only: no refracted rays to count.
    if (prepare<float>(scene).features.refraction) continue;
    const peer::EmbreeScene embree(scene);
    RenderOptions ro;
    ro.width = 1;
    ro.threads = 1;
    const RayCounts l = render(scene, ro).rays;
    for (int w : widths()) {
      const RayCounts e = embree.trace_all(w, 2).rays;
      EXPECT_EQ(e.camera, l.camera);
      const double tol = 1e-3 * double(l.total()) + 1;
      EXPECT_NEAR(double(e.shadow), double(l.shadow), tol) << "width " << w;
      EXPECT_NEAR(double(e.reflected), double(l.reflected), tol) << "width " << w;
    }
  }
}

TEST(EmbreePeer, RejectsWidthsThisMachineDoesNotRun) {
  if (!peer::embree_available()) GTEST_SKIP() << "built without Embree";
  const Scene scene = load_scene(std::string(LANCER_SOURCE_DIR) + "/scenes/flux2d.json");
  const peer::EmbreeScene embree(scene);
  EXPECT_THROW(embree.primary(3, 1), InputError);
}

TEST(EmbreePeer, WithoutEmbreeConstructionIsAnInputError) {
  if (peer::embree_available()) GTEST_SKIP() << "built with Embree";
  const Scene scene = load_scene(std::string(LANCER_SOURCE_DIR) + "/scenes/flux2d.json");
  EXPECT_THROW(peer::EmbreeScene{scene}, InputError);
}

// That a peak is measured where the ISA runs and refused where it does not; how fast it is
// belongs to the benchmarks (lancer bench --peak), not to a test that Debug and sanitizer
// builds must also pass.
TEST(Peak, EveryIsaThisCpuRunsHasAPeak) {
  for (int w : {1, 4, 8, 16}) {
    const bool runs = w == 1 || packet::kernels_for(w);
    const double g = peak_gflops(w, 0.02);
    if (!runs) {
      EXPECT_EQ(g, 0);
      continue;
    }
    EXPECT_GT(g, 0) << "width " << w;
    EXPECT_GT(peak_muladd_gflops(w, 0.02), 0) << "width " << w;
  }
}

TEST(Peak, PrimaryFlopsFollowTheCounts) {
  // One sphere that no camera ray reaches, and no plane: only the discriminant runs.
  Scene scene = parse_scene(R"({
    "camera": {"type": "pinhole", "position": [0, 0, 5], "direction": [0, 0, -1],
               "distance": 5, "resolution": [20, 10], "bounds": [-1, 1, -1, 1]},
    "objects": [{"type": "sphere", "center": [100, 0, 0], "radius": 1}]})",
                            "inline");
  PrimaryFlops f = primary_flops(scene, 1);
  EXPECT_EQ(f.sphere_hit_fraction, 0);
  EXPECT_EQ(f.per_ray, kSphereDiscFlops);
  EXPECT_EQ(f.per_lane, kSphereDiscFlops);
  // From the eye at width 4 (20 columns: no partial packet).
  f = primary_flops(scene, 4);
  EXPECT_EQ(f.per_ray, kSphereDiscFlopsFromEye);
  EXPECT_EQ(f.per_lane, kSphereDiscFlopsFromEye);
  // At width 16, the second packet of each row has 4 lanes of 16: all 16 execute.
  f = primary_flops(scene, 16);
  EXPECT_DOUBLE_EQ(f.per_lane, kSphereDiscFlopsFromEye * 32.0 / 20.0);

  // A sphere filling the view, plus a plane: every ray takes the hit path.
  scene = parse_scene(R"({
    "camera": {"type": "pinhole", "position": [0, 0, 5], "direction": [0, 0, -1],
               "distance": 5, "resolution": [20, 10], "bounds": [-0.1, 0.1, -0.1, 0.1]},
    "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1},
                {"type": "plane", "point": [0, -2, 0], "normal": [0, 1, 0]}]})",
                      "inline");
  f = primary_flops(scene, 8);
  EXPECT_EQ(f.sphere_hit_fraction, 1);
  EXPECT_EQ(f.per_ray, kSphereDiscFlopsFromEye + kSphereHitFlopsFromEye + kPlaneFlops);
}

// ---- the CLI -------------------------------------------------------------------------------

struct CliRun {
  int status = -1;
  std::string out;
};

CliRun run(const std::string& args) {
  CliRun r;
  const std::string cmd = std::string(LANCER_CLI) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

const std::string kFlux = std::string(LANCER_SOURCE_DIR) + "/scenes/flux2d.json";

TEST(BenchCli, UnknownPeerIsAnInputError) {
  const CliRun r = run("bench " + kFlux + " --peer nonesuch --repeat 1");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("--peer"), std::string::npos) << r.out;
}

TEST(BenchCli, PeerEmbreeAddsRowsOrSaysItIsMissing) {
  const CliRun r = run("bench " + kFlux + " --peer embree --repeat 1 --json");
  if (!peer::embree_available()) {
    EXPECT_EQ(r.status, 2) << r.out;
    EXPECT_NE(r.out.find("--peer embree"), std::string::npos) << r.out;
    return;
  }
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  int embree_rows = 0;
  for (const auto& row : j["results"])
    if (row["engine"] == "embree") {
      ++embree_rows;
      EXPECT_EQ(row["isa"], "embree");
      EXPECT_GT(row["rays"].get<double>(), 0);
    }
  // Both modes at every width this machine runs.
  EXPECT_EQ(embree_rows, 2 * int(packet::supported_widths().size()));
}

TEST(BenchCli, PeakAddsPeaksAndFlopsToPrimaryRows) {
  const CliRun r = run("bench " + kFlux + " --peak --repeat 1 --json --mode primary --width 1");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  ASSERT_TRUE(j.contains("peak"));
  EXPECT_EQ(j["peak"].size(), packet::supported_widths().size());
  for (const auto& p : j["peak"]) EXPECT_GT(p["gflops"].get<double>(), 0);
  for (const auto& row : j["results"]) {
    ASSERT_TRUE(row.contains("gflops"));
    ASSERT_TRUE(row.contains("peak_fraction"));
    EXPECT_GT(row["peak_fraction"].get<double>(), 0);
    EXPECT_LT(row["peak_fraction"].get<double>(), 1.5);
  }
}

TEST(BenchCli, KernelModeAndPrecisionsAddTheirRows) {
  if (!packet::kernels_for(4)) GTEST_SKIP() << "no packet kernels on this machine";
  const CliRun r = run("bench " + kFlux +
                       " --mode kernel,primary --precision exact,fast --repeat 1 --json --peak");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  int kernel_rows = 0, fast_rows = 0;
  for (const auto& row : j["results"]) {
    EXPECT_GT(row["rays"].get<double>(), 0);
    if (row["mode"] == "kernel") {
      ++kernel_rows;
      EXPECT_GT(row["width"].get<int>(), 1);  // packets only
    }
    if (row["precision"] == "fast") ++fast_rows;
    // Flops are counted for exact rows, primary and kernel alike.
    EXPECT_EQ(row.contains("peak_fraction"), row["precision"] == "exact") << row.dump();
  }
  const int packets = int(packet::supported_widths(Precision::fast).size());
  EXPECT_EQ(kernel_rows, 2 * packets);
  EXPECT_EQ(fast_rows, 2 * packets);  // fast has no width 1
}

TEST(BenchCli, BadModesAndPrecisionsAreInputErrors) {
  const std::pair<std::string, std::string> cases[] = {
      {"--mode sideways", "--mode"},
      {"--precision auto", "--precision"},
      {"--precision exact,triple", "--precision"},
      {"--precision fast --width 1", "--width"},
      {"--mode kernel --width 1", "--mode kernel"}};
  for (const auto& [args, option] : cases) {
    const CliRun r = run("bench " + kFlux + " " + args + " --repeat 1");
    EXPECT_EQ(r.status, 2) << args << ": " << r.out;
    EXPECT_NE(r.out.find(option), std::string::npos) << args << ": " << r.out;
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  }
}

}  // namespace
}  // namespace lancer
