// Stability at the extremes: each precision against double, on scenes built to break float.
// Reported as the fraction of camera rays whose first hit (or miss) differs from the double
// reference's and the fraction of pixels off by more than 1/255 as displayed. No pixel of any
// valid scene may be NaN or infinite. The table these tests print is docs/precision.md's.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "lancer/compare.hpp"
#include "lancer/formulas.hpp"
#include "lancer/packet/api.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

using nlohmann::json;

struct Measure {
  double hit_mismatch = 0, off = 0;
  bool finite = true;
};

bool all_finite(const Image& im) {
  for (float v : im.rgb)
    if (!std::isfinite(v)) return false;
  return true;
}

Measure measure(const Scene& s, Precision p, int width) {
  RenderOptions truth, test;
  truth.precision = Precision::dbl, truth.width = 1;
  test.precision = p, test.width = width;
  const Image a = render(s, test).image, b = render(s, truth).image;
  const auto ia = render_primary_with_ids(s, test).id, ib = render_primary_with_ids(s, truth).id;
  std::size_t differ = 0;
  for (std::size_t k = 0; k < ia.size(); ++k) differ += ia[k] != ib[k];
  Measure m;
  m.hit_mismatch = double(differ) / double(ia.size());
  m.off = error_stats(a, b, 1.0 / 255.0).off_fraction;
  m.finite = all_finite(a) && all_finite(b);
  return m;
}

// Prints one row of the table and checks finiteness for every precision at its widest width.
void report(const std::string& name, const Scene& s, double max_exact_off = 1.0,
            double max_auto_off = 1.0) {
  std::printf("| %-34s |", name.c_str());
  for (Precision p : {Precision::exact, Precision::fast, Precision::automatic}) {
    const std::vector<int> widths = packet::supported_widths(p);
    if (widths.empty()) {  // fast precision is packets only: none under LANCER_MAX_WIDTH=1
      std::printf(" %8s %8s |", "-", "-");
      continue;
    }
    const int width = p == Precision::automatic ? 0 : widths.front();
    const Measure m = measure(s, p, width);
    std::printf(" %7.3f%% %7.3f%% |", 100 * m.hit_mismatch, 100 * m.off);
    EXPECT_TRUE(m.finite) << name << ": NaN or infinity in a pixel, precision " << to_string(p);
    if (p == Precision::exact) {
      EXPECT_LE(m.off, max_exact_off) << name;
    }
    if (p == Precision::fast) {  // b^2 - c only where it holds: no cliff in hit/miss
      EXPECT_LE(m.hit_mismatch, 0.001) << name;
    }
    if (p == Precision::automatic) {
      EXPECT_LE(m.off, max_auto_off) << name;
    }
  }
  std::printf(" %s\n", to_string(choose_precision(s).precision));
}

void table_header() {
  std::printf("| %-34s | %-17s | %-17s | %-17s | auto picks\n", "case (hit differs, pixels off)",
              "exact", "fast", "auto");
}

Scene from(const json& j) { return parse_scene(j.dump(), "extreme"); }

json camera(json pos, json dir, double d, double half, int n = 64) {
  return {{"type", "pinhole"}, {"position", pos},      {"direction", dir},
          {"distance", d},     {"resolution", {n, n}}, {"bounds", {-half, half, -half, half}}};
}

json lit(json j, double intensity = 1) {
  j["lights"] = {{{"position", {10, 20, 30}}, {"intensity", intensity}, {"ambient", 0.2}}};
  return j;
}

json sphere(json c, double r, json material = json::object()) {
  json o = {{"type", "sphere"}, {"center", c}, {"radius", r}};
  if (!material.empty()) o["material"] = material;
  return o;
}

// Tiny spheres far away: radius / distance from 1e-2 to 1e-6, framed to fill the image.
TEST(Extremes, TinySpheresFarAway) {
  table_header();
  for (double ratio : {1e-2, 1e-3, 1e-4, 1e-5, 1e-6}) {
    const double dist = 100.0, r = ratio * dist;
    json j = lit({{"camera", camera({0, 0, 0}, {0, 0, -1}, 1, 2.5 * ratio)},
                  {"epsilon", 1e-4 * r},
                  {"objects", {sphere({0.3 * r, 0, -dist}, r, {{"ks", 1}})}}});
    char name[64];
    std::snprintf(name, sizeof name, "sphere r/dist %g", ratio);
    // Issue 17: 8.7% of pixels off at 1e-6 before hit points were computed relative to the
    // sphere; now none (docs/precision.md).
    report(name, from(j), 0.005, 0.005);
  }
}

TEST(Extremes, HugeSphereAsGround) {
  json j = lit({{"camera", camera({0, 1, 5}, {0, -0.3, -1}, 1, 1)},
                {"objects",
                 {sphere({0, -1e6, 0}, 1e6, {{"color", {0.8, 0.6, 0.5}}}),
                  sphere({0, 0.5, -3}, 0.5, {{"ks", 1}, {"reflect", 0.3}})}},
                {"max_depth", 2}});
  report("ground sphere r 1e6", from(j), 0.01, 0.005);
}

// The shadows scene moved away from the origin: float's spacing grows with the coordinates.
TEST(Extremes, TranslatedScenes) {
  for (double offset : {1e3, 1e4, 1e5, 1e6}) {
    json j = json::parse(std::ifstream(testing::source_path("scenes/lorenzi-shadows.json")));
    auto move = [&](json& v) { v[0] = v[0].get<double>() + offset; };
    move(j["camera"]["position"]);
    for (auto& l : j["lights"]) move(l["position"]);
    for (auto& o : j["objects"]) move(o.contains("center") ? o["center"] : o["point"]);
    j["camera"]["resolution"] = {150, 100};
    char name[64];
    std::snprintf(name, sizeof name, "lorenzi-shadows moved by %g", offset);
    report(name, from(j), 0.005, 0.005);
  }
}

// Rays tangent to a sphere: an orthographic strip of rays across its silhouette, 1e-3 wide.
TEST(Extremes, GrazingRays) {
  json j = lit({{"camera",
                 {{"type", "orthographic"},
                  {"position", {0, 0, 10}},
                  {"direction", {0, 0, -1}},
                  {"resolution", {200, 4}},
                  {"bounds", {1 - 1e-3, 1 + 1e-3, -1e-4, 1e-4}}}},
                {"objects", {sphere({0, 0, 0}, 1, {{"ks", 0.5}})}}});
  report("grazing rays (disc ~ 0)", from(j));
}

TEST(Extremes, RaysParallelToPlanes) {
  // The eye lies in the plane y = 0; rays through the middle row run along it.
  json j = lit({{"camera", camera({0, 0, 0}, {0, 0, -1}, 1, 1, 63)},
                {"objects",
                 {{{"type", "plane"}, {"point", {0, 0, 0}}, {"normal", {0, 1, 0}}},
                  sphere({0, 0.2, -4}, 0.5)}}});
  report("eye in a plane, parallel rays", from(j));
}

TEST(Extremes, RayOriginsOnSurfaces) {
  // The eye on a sphere's surface, looking out through it, and on a plane.
  json j = lit({{"camera", camera({0, 0, 1}, {0, 0, 1}, 1, 1)},
                {"objects",
                 {sphere({0, 0, 0}, 1),
                  sphere({0, 0, 4}, 1, {{"ks", 1}}),
                  {{"type", "plane"}, {"point", {0, -1, 0}}, {"normal", {0, 1, 0}}}}}});
  report("eye on a sphere's surface", from(j));
}

TEST(Extremes, ShininessExtremes) {
  for (double shininess : {0.0, 1.0, 1e4}) {
    json j = lit({{"camera", camera({0, 0, 5}, {0, 0, -1}, 5, 2)},
                  {"objects", {sphere({0, 0, 0}, 1, {{"ks", 1}, {"shininess", shininess}})}}});
    char name[64];
    std::snprintf(name, sizeof name, "shininess %g", shininess);
    report(name, from(j), 0.01, 0.005);
  }
}

TEST(Extremes, IntensityExtremes) {
  for (double intensity : {1e-30, 1e30}) {
    json j = lit({{"camera", camera({0, 0, 5}, {0, 0, -1}, 5, 2)},
                  {"objects", {sphere({0, 0, 0}, 1, {{"ks", 1}})}}},
                 intensity);
    char name[64];
    std::snprintf(name, sizeof name, "intensity %g", intensity);
    report(name, from(j), 1.0, 0.005);
  }
}

TEST(Extremes, DeepReflectionBetweenParallelMirrors) {
  const json mirror = {{"ka", 0.05}, {"kd", 0.2}, {"reflect", 0.95}};
  json j = lit(
      {{"camera", camera({0, 0, 0}, {0.1, 0, -1}, 1, 0.5)},
       {"max_depth", 64},
       {"objects",
        {{{"type", "plane"}, {"point", {0, 0, -5}}, {"normal", {0, 0, 1}}, {"material", mirror}},
         {{"type", "plane"}, {"point", {0, 0, 5}}, {"normal", {0, 0, -1}}, {"material", mirror}},
         sphere({1, 0, -2}, 0.5)}}});
  report("max_depth 64, parallel mirrors", from(j), 0.01, 0.005);
}

// Ray/sphere classification, robust (Ray Tracing Gems ch. 7) against the naive quadratic, both in
// float, against double, on the same float rays. Rays aim at random points of a disc 1.5 times the
// sphere's size seen from the origin, so about 44% hit and many pass near the silhouette.
struct Classified {
  double robust_agree, naive_agree;
};

Classified classify(double ratio, int rays, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  const double dist = 1.0, r = ratio * dist;
  const Vec3<float> c{0.0f, 0.0f, float(-dist)};
  const float r2 = float(r) * float(r);
  int robust_ok = 0, naive_ok = 0;
  for (int k = 0; k < rays; ++k) {
    double x, y;
    do x = u(rng), y = u(rng);
    while (x * x + y * y > 1);
    const Vec3<float> d =
        normalize(Vec3<float>{float(1.5 * r * x), float(1.5 * r * y), float(-dist)});
    // Truth: the same float ray and sphere, in double.
    const Vec3<double> dd{d.x, d.y, d.z}, fd{-double(c.x), -double(c.y), -double(c.z)};
    const double bd = dot(fd, dd);
    const Vec3<double> perp = fd - dd * bd;
    const bool truth = double(r2) - dot(perp, perp) >= 0;
    // Robust float.
    const Vec3<float> f = -c;
    const bool robust = sphere_disc(f, d, r2).disc >= 0.0f;
    // Naive float: b^2 - c with c = |f|^2 - r^2.
    const float b = dot(f, d), cc = dot(f, f) - r2;
    const bool naive = b * b - cc >= 0.0f;
    robust_ok += robust == truth;
    naive_ok += naive == truth;
  }
  return {double(robust_ok) / rays, double(naive_ok) / rays};
}

// Fast mode's own budget (issue: at most 0.5% of pixels off by more than 1/255) on the scene its
// speed is measured on, at every width; and where it may use the textbook discriminant.
TEST(FastMode, LorenziReflectionsWithinItsBudget) {
  const Scene s = load_scene(testing::source_path("scenes/lorenzi-reflections.json"));
  for (int width : packet::supported_widths(Precision::fast)) {
    const Measure m = measure(s, Precision::fast, width);
    EXPECT_LE(m.off, 0.005) << "width " << width;
    EXPECT_LE(m.hit_mismatch, 0.001) << "width " << width;
    EXPECT_TRUE(m.finite) << "width " << width;
  }
}

// Fast mode skips, for a ray leaving a sphere from outside, that sphere's roots (convexity).
// From inside, the ray meets the same sphere again: inside a mirrored sphere, every reflection
// and every shadow ray does. Skipping there would send them out to the environment.
TEST(FastMode, RaysInsideASphereStillMeetIt) {
  const json mirror = {{"color", 0.9}, {"ka", 0.1}, {"kd", 0.4}, {"ks", 0.5}, {"reflect", 0.6}};
  json j = {{"camera", camera({0, 0, 0}, {0, 0, -1}, 1, 0.6)},
            {"environment", {1, 1, 0}},
            {"max_depth", 4},
            {"lights", {{{"position", {0.5, 0.5, 0.5}}, {"intensity", 1}, {"ambient", 0.2}}}},
            {"objects", {sphere({0, 0, 0}, 3, mirror), sphere({0.5, -0.3, -1.5}, 0.4)}}};
  const Scene s = from(j);
  for (int width : packet::supported_widths(Precision::fast)) {
    const Measure m = measure(s, Precision::fast, width);
    EXPECT_LE(m.off, 0.005) << "width " << width;
    EXPECT_TRUE(m.finite) << "width " << width;
  }
}

// Issue 13: fast mode's convexity shortcuts (a ray leaving a sphere from outside skips it; a
// light behind the surface is blocked by it) do not hold through glass: a refracted ray meets
// the sphere it enters again, and a shadow ray through a glass sphere is dimmed, not stopped.
// A glass sphere lit from behind, seen in front of a plane, and the shipped glass scenes.
TEST(FastMode, GlassWithinItsBudget) {
  const json glass = {{"color", 1},      {"ka", 0.05},     {"kd", 0.1},        {"ks", 1},
                      {"shininess", 50}, {"reflect", 0.1}, {"transmit", 0.85}, {"ior", 1.5}};
  const json ground = {{"color", {0.9, 0.7, 0.5}}, {"ka", 0.2}, {"kd", 0.8}};
  json j = {{"camera", camera({0, 0, 6}, {0, 0, -1}, 2, 1)},
            {"max_depth", 4},
            {"lights",
             {{{"position", {1, 2, -8}}, {"intensity", {1, 0.8, 0.6}}, {"ambient", 0.2}},
              {{"position", {3, 4, 6}}, {"intensity", 0.6}}}},
            {"objects",
             {sphere({0, 0, 0}, 1.2, glass),
              sphere({1.5, 0.5, -3}, 0.8),
              {{"type", "plane"},
               {"point", {0, -1.3, 0}},
               {"normal", {0, 1, 0}},
               {"material", ground}}}}};
  std::vector<Scene> scenes{from(j)};
  for (const char* name : {"scenes/lorenzi-glass.json", "scenes/glass-tir.json"})
    scenes.push_back(load_scene(testing::source_path(name)));
  for (const Scene& s : scenes) {
    for (int width : packet::supported_widths(Precision::fast)) {
      const Measure m = measure(s, Precision::fast, width);
      EXPECT_LE(m.off, 0.005) << s.name << " width " << width;
      EXPECT_LE(m.hit_mismatch, 0.001) << s.name << " width " << width;
      EXPECT_TRUE(m.finite) << s.name << " width " << width;
    }
  }
}

TEST(FastMode, TextbookDiscriminantOnlyWhereItHolds) {
  auto holds = [](double radius, double dist) {
    json j = lit({{"camera", camera({0, 0, 0}, {0, 0, -1}, 1, 1)},
                  {"objects", {sphere({0, 0, -dist}, radius), sphere({0, 2, -3}, 1)}}});
    return prepare<float>(from(j)).naive_spheres_hold;
  };
  EXPECT_TRUE(holds(1, 10));
  EXPECT_TRUE(holds(1, 256));
  EXPECT_FALSE(holds(1, 257));
  EXPECT_FALSE(holds(1e-3, 1));
  // Seen from within a radius of its surface, or from inside: the roots' ulps of |b| matter.
  EXPECT_TRUE(holds(5, 10));
  EXPECT_FALSE(holds(6, 10));
  EXPECT_FALSE(holds(1e6, 1e6 + 2));
  EXPECT_TRUE(prepare<float>(load_scene(testing::source_path("scenes/lorenzi-reflections.json")))
                  .naive_spheres_hold);
}

TEST(Extremes, RobustSphereTestAgainstNaive) {
  std::printf("| radius/distance | robust float agrees | naive float agrees |\n");
  for (double ratio : {1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6}) {
    const Classified c = classify(ratio, 200000, 42);
    std::printf("| %15g | %18.4f%% | %17.4f%% |\n", ratio, 100 * c.robust_agree,
                100 * c.naive_agree);
    if (ratio >= 1e-4) {
      EXPECT_GE(c.robust_agree, 0.9999) << "ratio " << ratio;
    }
    if (ratio <= 1e-3) {
      EXPECT_LT(c.naive_agree, c.robust_agree) << "ratio " << ratio;
    }
  }
}

// Regression (found by tests/fuzz's random extreme scenes, seed 1592592339): a sphere of radius
// 0.0022 hit from 833 229 units away, inside a sphere of radius 833 224. Float put the hit point
// more than a radius off the small sphere, so (P - C) / r was no unit vector and
// max(0, n.h)^248 overflowed to infinity in every exact path. Normals are now normalize(P - C).
TEST(Extremes, RegressionHugeRatioNormalStaysUnit) {
  const Scene s = parse_scene(
      R"json({"background":13.302387326305087,"camera":{"bounds":[-0.0028929095709333023,0.0028929095709333023,-0.0017357457425599813,0.0017357457425599813],"direction":[-0.00021300084227959815,-0.01895005954173712,0.0022593820785139253],"distance":0.019086463928626514,"position":[142.5028297268132,-325.8753489362518,-0.0022593820785139253],"resolution":[13,7],"type":"pinhole"},"environment":0.20081863085515317,"epsilon":2.2168076990862738e-07,"lights":[{"ambient":3.6651902538281145e-28,"intensity":0.00019688123224410637,"position":[0.003610918427886144,160518.14571400677,0.009362893223054529]},{"ambient":7.777187556240758e+18,"intensity":4.111023838859243e-19,"position":[241.7176144644219,-4049.0445449829926,68.69838284870218]}],"max_depth":4,"objects":[{"center":[0.0,0.08881240260092461,0.028152485386231944],"material":{"color":0.07034900501678609,"ka":0.9476149097829323,"kd":0.5546920058644115,"ks":0.7937598242100052,"reflect":0.28230852966681236,"shininess":133.95435501564054},"radius":0.00049296404461191,"type":"sphere"},{"center":[-1211.9535982414066,-21670.053870657135,-0.00402833871255136],"material":{"color":[0.7671167627428418,0.5762682372583714,0.7155373125671155],"ka":0.4478953997346691,"kd":0.06167354571151118,"ks":0.3990379006082163,"reflect":0.5614557901828694,"shininess":194.59719955655797},"radius":0.0006191279797295787,"type":"sphere"},{"center":[-0.1170018069319957,-327.5103804428406,0.0],"material":{"color":[0.6724221293689044,0.3642898116727542,0.9686140860061596],"ka":0.0,"kd":0.16284785805627922,"ks":0.0,"reflect":0.41214377675191394,"shininess":142.16268836177906},"radius":833224.607493961,"type":"sphere"},{"center":[142.5026167259709,-325.8942989957935,0.0],"material":{"color":[0.23366672149786383,0.0136343625641413,0.858227458767072],"ka":0.7577736588133923,"kd":0.5328986291264245,"ks":0.14455349210393842,"reflect":0.5407301476092863,"shininess":248.0},"radius":0.0022168076990862736,"type":"sphere"}]})json",
      "regression");
  for (Precision p : {Precision::exact, Precision::fast, Precision::dbl}) {
    for (int width : packet::supported_widths(p)) {
      RenderOptions opt;
      opt.precision = p, opt.width = width;
      EXPECT_TRUE(all_finite(render(s, opt).image)) << to_string(p) << " width " << width;
    }
  }
}

}  // namespace
}  // namespace lancer
