// Issue 17: float that holds at the extremes. Sphere hit points are computed relative to small
// spheres (formulas.hpp sphere_point_local) and secondary rays leave them by the error made, so
// exact float stays within 0.5% of pixels off by more than 2/255 of double on tiny spheres far
// away, ground spheres of radius 1e6 and scenes moved 1e5 from the origin; `auto` picks float
// wherever the envelope (choose_precision) says it holds, and stays within 0.5% everywhere.
// Scenes are seeded (log-uniform magnitudes), built as scripts/extremes.py builds its own.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "lancer/compare.hpp"
#include "lancer/formulas.hpp"
#include "lancer/generate.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/prepared.hpp"
#include "lancer/render.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

using nlohmann::json;
using V3 = std::array<double, 3>;

constexpr double kBudget = 0.005;  // of pixels off by more than 2/255

V3 add(const V3& a, const V3& b, double s = 1) {
  return {a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]};
}
V3 unit(const V3& v) {
  const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  return {v[0] / n, v[1] / n, v[2] / n};
}
V3 cross(const V3& a, const V3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
V3 random_unit(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  for (;;) {
    const V3 v{u(rng), u(rng), u(rng)};
    const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (n > 0.1 && n <= 1) return unit(v);
  }
}
double log_uniform(std::mt19937_64& rng, double lo, double hi) {
  return std::pow(10.0,
                  std::uniform_real_distribution<double>(std::log10(lo), std::log10(hi))(rng));
}

const json kShiny = {{"color", {0.9, 0.8, 0.7}}, {"ka", 0.1},     {"kd", 0.7}, {"ks", 0.6},
                     {"shininess", 30},          {"reflect", 0.3}};
const json kMatte = {{"color", {0.4, 0.7, 0.9}}, {"ka", 0.1}, {"kd", 0.9}};

// A sphere of radius ratio * distance filling the frame, a smaller one beside it that shadows
// it and is seen in it (0.39 radii apart). Axis-aligned (the eye at the origin looking down -z,
// 100 away) without rng, else from a random position, in a random direction, at a random
// distance.
json tiny_far(double ratio, std::mt19937_64* rng = nullptr, int n = 80) {
  V3 eye{0, 0, 0}, dir{0, 0, -1};
  double dist = 100;
  if (rng) {
    const V3 e = random_unit(*rng);
    const double m = log_uniform(*rng, 1, 1e3);
    eye = {e[0] * m, e[1] * m, e[2] * m};
    dir = random_unit(*rng);
    dist = log_uniform(*rng, 1, 1e4);
  }
  const double r = ratio * dist;
  const V3 a = std::fabs(dir[0]) < 0.9 ? V3{1, 0, 0} : V3{0, 1, 0};
  const V3 u = unit(cross(a, dir)), v = cross(dir, u);
  const V3 centre = add(add(eye, dir, dist), u, 0.3 * r);
  const V3 small = add(add(centre, u, -1.6 * r), dir, -0.8 * r);
  const V3 light = add(add(centre, v, 30 * r), dir, -20 * r);
  const double half = 2.5 * ratio;
  return {{"camera",
           {{"type", "pinhole"},
            {"position", eye},
            {"direction", dir},
            {"distance", 1},
            {"resolution", {n, n}},
            {"bounds", {-half, half, -half, half}}}},
          {"epsilon", 1e-4 * r},
          {"max_depth", 2},
          {"background", {0.1, 0.1, 0.2}},
          {"environment", {0.3, 0.3, 0.3}},
          {"lights",
           {{{"position", light}, {"intensity", 1}, {"ambient", 0.2}},
            {{"position", add(eye, u, 10 * r)}, {"intensity", 0.5}}}},
          {"objects",
           {{{"type", "sphere"}, {"center", centre}, {"radius", r}, {"material", kShiny}},
            {{"type", "sphere"}, {"center", small}, {"radius", 0.4 * r}, {"material", kMatte}}}}};
}

// A ground sphere of radius 1e6 seen from 0.5 to 4 units above it, a ball on it.
json ground(std::mt19937_64& rng, int n = 80) {
  std::uniform_real_distribution<double> u(0, 1);
  const double R = 1e6;
  const V3 top{2e3 * u(rng) - 1e3, 20 * u(rng) - 10, 2e3 * u(rng) - 1e3};
  const double h = 0.5 + 3.5 * u(rng), yaw = 2 * M_PI * u(rng);
  const V3 eye{top[0], top[1] + h, top[2]};
  const V3 look{std::cos(yaw), -(0.15 + 0.35 * u(rng)), std::sin(yaw)};
  const V3 ahead = add(eye, unit({look[0], 0, look[2]}), 4 * h);
  return {{"camera",
           {{"type", "pinhole"},
            {"position", eye},
            {"direction", look},
            {"distance", 1},
            {"resolution", {n, n}},
            {"bounds", {-0.8, 0.8, -0.8, 0.8}}}},
          {"lights", {{{"position", add(eye, {30, 40, 20})}, {"intensity", 1}, {"ambient", 0.2}}}},
          {"max_depth", 2},
          {"environment", {0.5, 0.6, 0.8}},
          {"objects",
           {{{"type", "sphere"},
             {"center", V3{top[0], top[1] - R, top[2]}},
             {"radius", R},
             {"material", {{"color", {0.8, 0.6, 0.5}}, {"kd", 0.9}, {"ks", 0.3}}}},
            {{"type", "sphere"},
             {"center", V3{ahead[0], top[1] + 0.5, ahead[2]}},
             {"radius", 0.5},
             {"material", kShiny}}}}};
}

// A course scene moved by `offset` along a random direction.
json moved(const char* name, double offset, std::mt19937_64& rng, int n = 90) {
  json j = json::parse(std::ifstream(testing::source_path(std::string("scenes/") + name)));
  const V3 d = random_unit(rng);
  auto move = [&](json& v) {
    for (int c = 0; c < 3; ++c) v[c] = v[c].get<double>() + offset * d[c];
  };
  move(j["camera"]["position"]);
  for (auto& l : j["lights"]) move(l["position"]);
  for (auto& o : j["objects"]) move(o.contains("center") ? o["center"] : o["point"]);
  j["camera"]["resolution"] = {n, n * 2 / 3};
  return j;
}

Scene from(const json& j) { return parse_scene(j.dump(), "envelope"); }

// Pixels off by more than 2/255 as displayed, precision p at its widest width (auto: as it
// chooses) against the double reference.
double off(const Scene& s, Precision p, const Image& truth) {
  const int width = p == Precision::automatic ? 0 : packet::supported_widths(p).front();
  return error_stats(testing::render_with(s, width, p, 2), truth, 2.0 / 255).off_fraction;
}

struct Row {
  double exact, automatic;
  Precision picked;
};
Row measure(const std::string& name, const Scene& s) {
  const Image truth = testing::render_with(s, 1, Precision::dbl, 2);
  const Row row{off(s, Precision::exact, truth), off(s, Precision::automatic, truth),
                choose_precision(s).precision};
  std::printf("| %-32s | %7.3f%% | %7.3f%% | %s\n", name.c_str(), 100 * row.exact,
              100 * row.automatic, to_string(row.picked));
  EXPECT_LE(row.automatic, kBudget) << name << ": auto outside its budget";
  return row;
}

TEST(FloatEnvelope, TinySpheresFarAway) {
  // Along an axis, float's rays and centres are exact across the view: only the hit point's
  // rounding along the ray was left, 6% of the radius at 1e-6 (4.9% of pixels off before).
  for (double ratio : {1e-3, 1e-4, 1e-5, 1e-6}) {
    char name[64];
    std::snprintf(name, sizeof name, "tiny axis-aligned %g", ratio);
    EXPECT_LE(measure(name, from(tiny_far(ratio))).exact, kBudget) << name;
  }
  // In general position, in the world's coordinates, float's rays and centres were off by 2^-24
  // of the distance across the view (7% to 10% of pixels off at 1e-6). In the camera's frame
  // they are off by 2^-24 of what the view spans: float holds to 1e-6 (measured: 0.30% at worst),
  // not asserted at 1e-7 (up to 2.3%). Auto takes double below 5e-6 of the extent, where two
  // spheres shadowing each other start to show float's spacing along the view
  // (HoldsAtTheEnvelopesEdge).
  for (double ratio : {1e-3, 1e-4, 3e-5, 1e-5, 1e-6, 1e-7}) {
    for (int seed = 1; seed <= 3; ++seed) {
      std::mt19937_64 rng(std::uint64_t(seed) * 7919 + std::uint64_t(-std::log10(ratio) * 10));
      char name[64];
      std::snprintf(name, sizeof name, "tiny general %g seed %d", ratio, seed);
      const Row row = measure(name, from(tiny_far(ratio, &rng)));
      if (ratio >= 1e-6) {
        EXPECT_LE(row.exact, kBudget) << name;
      }
    }
  }
}

TEST(FloatEnvelope, GroundSpheresAndScenesFarFromTheOrigin) {
  for (int seed = 1; seed <= 3; ++seed) {
    std::mt19937_64 rng(std::uint64_t(seed) * 104729);
    const std::string name = "ground sphere 1e6 seed " + std::to_string(seed);
    EXPECT_LE(measure(name, from(ground(rng))).exact, kBudget) << name;
  }
  std::mt19937_64 rng(17);
  for (const char* scene :
       {"lorenzi-shadows.json", "lorenzi-reflections.json", "lorenzi-glass.json"}) {
    for (double offset : {1e5, 1e6}) {
      const std::string name = std::string(scene) + " moved " + std::to_string(int(offset));
      EXPECT_LE(measure(name, from(moved(scene, offset, rng))).exact, kBudget) << name;
    }
  }
}

// Regression, the issue's case: a sphere of radius 1e-6 of its distance along the view axis, a
// neighbour shadowing it from 0.39 radii, epsilon 1% of the radius. Exact float put 4.7% of its
// pixels more than 2/255 off double (the oracle agrees with double to 0.004%): the normals from
// o + t d, and secondary rays moved four radii off the surface, into the neighbour. Not under
// scenes/: the shipped scenes are held to float's envelope, and this one is outside it.
TEST(FloatEnvelope, RegressionTinyFarSphereWithANeighbour) {
  const Scene s = parse_scene(R"json({
    "camera": {"type": "pinhole", "position": [0, 0, 0], "direction": [0, 0, -1], "distance": 1,
               "resolution": [160, 160], "bounds": [-2.5e-6, 2.5e-6, -2.5e-6, 2.5e-6]},
    "epsilon": 1e-6, "max_depth": 2, "background": [0.1, 0.1, 0.2], "environment": 0.3,
    "lights": [{"position": [0, 0.003, -99.998], "intensity": 1, "ambient": 0.2},
               {"position": [0.001, 0, 0], "intensity": 0.5}],
    "objects": [
      {"type": "sphere", "center": [3e-5, 0, -100], "radius": 1e-4,
       "material": {"color": [0.9, 0.8, 0.7], "ka": 0.1, "kd": 0.7, "ks": 0.6, "shininess": 30,
                    "reflect": 0.3}},
      {"type": "sphere", "center": [-1.3e-4, 0, -99.99992], "radius": 4e-5,
       "material": {"color": [0.4, 0.7, 0.9], "ka": 0.1, "kd": 0.9}}]})json",
                              "tiny-far-sphere");
  EXPECT_LE(measure("tiny far sphere, neighbour", s).exact, kBudget);
}

// Auto picks float on the extreme scenes it now holds on, where it picked double before (the
// smallest sphere was below 4e-5 of the extent before the camera's frame, 1e-4 before that).
// Far spheres alone move the frame's origin to them (Frame::depth): then the bound is against
// their spread, and tiny spheres however far hold.
TEST(FloatEnvelope, AutoPicksFloatWhereItNowHolds) {
  std::mt19937_64 rng(3);
  for (double ratio : {1e-3, 1e-4, 1e-5, 1e-6, 1e-7}) {
    EXPECT_EQ(choose_precision(from(tiny_far(ratio))).precision, Precision::exact) << ratio;
    EXPECT_EQ(choose_precision(from(tiny_far(ratio, &rng))).precision, Precision::exact) << ratio;
  }
  // No depth: a sphere near the eye (the spheres' spread is their distance), or a plane.
  json near = tiny_far(1e-5);
  near["objects"].push_back({{"type", "sphere"}, {"center", {0, -2, -5}}, {"radius", 1}});
  EXPECT_EQ(choose_precision(from(near)).precision, Precision::dbl);
  near["objects"].back()["center"] = {0, -2, -5e3};  // 2e-6 of the extent: still double
  EXPECT_EQ(choose_precision(from(near)).precision, Precision::dbl);
  json ground = tiny_far(3e-5);
  ground["objects"].push_back({{"type", "plane"}, {"point", {0, -1, 0}}, {"normal", {0, 1, 0}}});
  EXPECT_EQ(choose_precision(from(ground)).precision, Precision::dbl);
  EXPECT_EQ(choose_precision(from(tiny_far(3e-5))).precision, Precision::exact);
}

// At the envelope's edge, in the orientation where it is widest against the sphere's distance
// (the extent is the largest coordinate: a view along (1, 1, -1) has it at distance / sqrt(3)):
// two spheres of radius 1.05 times the envelope's bound, one shadowing the other, and a third
// behind the eye, so that the frame stays at the eye (no depth), auto picks float and float
// holds: the sphere is 3e-6 of its distance there (measured, 6 seeds: 0.39% at worst; at 3e-6
// of the extent 0.50%, at 1e-6 0.81%, at 1e-5 0.20%, at 4e-5 0.03%, which was 0.37% in the
// world's frame). With depth (no third sphere) no pixel is off even at 1e-8 of the extent.
TEST(FloatEnvelope, HoldsAtTheEnvelopesEdge) {
  for (int seed = 0; seed < 6; ++seed) {
    std::mt19937_64 rng(std::uint64_t(seed) + 900);
    std::uniform_real_distribution<double> u(-0.05, 0.05);
    const V3 d = unit({1 + u(rng), 1 + u(rng), -1 + u(rng)});
    const double dist = log_uniform(rng, 1, 1e4);
    const double extent = dist * std::max({std::fabs(d[0]), std::fabs(d[1]), std::fabs(d[2])});
    const double r = 5e-6 * 1.05 * extent;
    json j = tiny_far(r / dist);
    const V3 a{1, 0, 0}, e1 = unit(cross(a, d)), e2 = cross(d, e1);
    const V3 centre = add(add(V3{0, 0, 0}, d, dist), e1, 0.3 * r);
    j["camera"]["direction"] = d;
    j["objects"][0]["center"] = centre;
    j["objects"][1]["center"] = add(add(centre, e1, -2.2 * r), d, -0.8 * r);
    j["objects"][0]["radius"] = r;
    j["objects"][1]["radius"] = r;
    j["lights"][0]["position"] = add(add(centre, e2, 30 * r), d, -20 * r);
    j["lights"][1]["position"] = add(V3{0, 0, 0}, e1, 10 * r);
    j["epsilon"] = 1e-4 * r;
    j["objects"].push_back({{"type", "sphere"},
                            {"center", add(V3{0, 0, 0}, d, -0.1 * dist)},
                            {"radius", 0.01 * dist}});
    const Scene s = from(j);
    ASSERT_EQ(camera_frame<float>(s).depth, 0);
    const std::string name = "envelope edge seed " + std::to_string(seed);
    const Row row = measure(name, s);
    EXPECT_EQ(row.picked, Precision::exact) << name << ": " << choose_precision(s).reason;
    EXPECT_LE(row.exact, kBudget) << name;
  }
}

// A generated cloud of spheres seen from K times further back through a K times narrower window
// (a telescope), with and without its ground plane. Without it the spheres lie far beyond the
// eye against their spread and the frame's origin moves to them (Frame::depth): exact holds
// far beyond auto's bound (measured 0.02% at K = 4000, 5.5e-6 of the extent, 0.4% before the
// depth). With it, no depth: plane hits are o + t d, off by ulps of the distance, and auto keeps
// double from 4e-5 of the extent on (measured: exact 0.94% off at K = 4000, 0.11% at 500).
TEST(FloatEnvelope, TelescopeViewsOfACloud) {
  generate::Options g;
  g.spheres = 300;
  g.nx = 96, g.ny = 64;
  for (bool plane : {true, false}) {
    g.plane = plane;
    const json cloud = json::parse(generate::scene_json(g));
    for (double k : {5e2, 4e3, 3e4}) {
      json j = cloud;
      json& cam = j["camera"];
      const V3 d = unit(cam["direction"].get<V3>());
      const V3 target = add(cam["position"].get<V3>(), d, 6);  // about the cloud's middle
      cam["position"] = add(target, d, -6 * k);
      cam["distance"] = cam.value("distance", 1.0) * k;
      char name[64];
      std::snprintf(name, sizeof name, "telescope x%g%s", k, plane ? ", ground plane" : "");
      const Row row = measure(name, from(j));
      if (!plane) {
        EXPECT_LE(row.exact, kBudget) << name;
      }
    }
  }
}

// Epsilon is no longer in the envelope: offsets, not epsilon, keep secondary rays off their
// surface, so an epsilon far below float's spacing changes nothing float computes worse.
TEST(FloatEnvelope, TinyEpsilonChangesNothing) {
  for (const std::string& path : testing::shipped_scenes()) {
    json j = json::parse(std::ifstream(path));
    if (choose_precision(from(j)).precision != Precision::exact) continue;
    j["epsilon"] = 1e-30;
    const Scene s = from(j);
    const Image truth = testing::render_with(s, 1, Precision::dbl, 2);
    EXPECT_LE(off(s, Precision::exact, truth), 1e-4) << path;
    EXPECT_EQ(choose_precision(s).precision, Precision::exact) << path;
  }
}

// The formula itself, against double on the same float inputs: rays from the origin at random
// points of small spheres in general position (radius/distance 1e-2 to 1e-6, log-uniform).
// The normal is within 1e-4 of double's (measured: 1e-5), where o + t d put it off by up to a
// fifth (measured: 0.18); the
// offset origins lie outside the sphere on the normal's side and inside on the other.
TEST(FloatEnvelope, SpherePointRelativeToTheSphere) {
  std::mt19937_64 rng(1717);
  std::uniform_real_distribution<double> u(-1, 1);
  double worst_local = 0, worst_along = 0;
  int hits = 0;
  for (int k = 0; k < 20000; ++k) {
    const double ratio = log_uniform(rng, 1e-6, 1e-2), dist = log_uniform(rng, 1, 1e4);
    const V3 w = random_unit(rng);
    const Vec3<float> c{float(w[0] * dist), float(w[1] * dist), float(w[2] * dist)};
    const float r = float(ratio * dist), r2 = r * r;
    // Aim at a random point of the sphere's disc, as seen from the origin.
    const V3 a = std::fabs(w[0]) < 0.9 ? V3{1, 0, 0} : V3{0, 1, 0};
    const V3 e1 = unit(cross(a, w)), e2 = cross(w, e1);
    double x, y;
    do x = u(rng), y = u(rng);
    while (x * x + y * y > 1);
    const V3 aim = add(add(V3{c.x, c.y, c.z}, e1, x * r), e2, y * r);
    const Vec3<float> d = normalize(Vec3<float>{float(aim[0]), float(aim[1]), float(aim[2])});
    const Vec3<float> o{0, 0, 0};
    const SphereDisc<float> sd = sphere_disc(o - c, d, r2);
    if (!(sd.disc >= 0.0f)) continue;
    const float t = sphere_first_root(sphere_roots(sd, sphere_c(o - c, r2)), 0.0f);
    const float m = hit_magnitude(o, t);
    ASSERT_TRUE(bool(sphere_is_small(r2, m)));
    const SurfacePoint<float> local = sphere_point_local<float>(o, d, t, c, r2);
    const SurfacePoint<float> along = sphere_point_along<float>(o, d, t, c, m);
    // Double on the same float ray and sphere: the line through the float direction, made unit
    // (float's is 1 to an ulp, and f - (f.d) d keeps (1 - |d|^2)|f| of it along d: a tenth of
    // the radius at 1e-6, of which d x (f x d) keeps nothing).
    const Vec3<double> dd = normalize(Vec3<double>{d.x, d.y, d.z}), cd{c.x, c.y, c.z};
    const SphereDisc<double> sdd = sphere_disc(-cd, dd, double(r2));
    if (!(sdd.disc >= 0)) continue;  // a grazing ray float's discriminant let through
    const double td = sphere_first_root(sphere_roots(sdd, sphere_c(-cd, double(r2))), 0.0);
    const Vec3<double> nd = normalize(dd * td - cd);
    auto error = [&](const Vec3<float>& n) { return length(Vec3<double>{n.x, n.y, n.z} - nd); };
    worst_local = std::max(worst_local, error(local.normal));
    worst_along = std::max(worst_along, error(along.normal));
    ++hits;
    EXPECT_LE(error(local.normal), 1e-4) << "ratio " << ratio << " dist " << dist;
    // Offset origins, each side, measured in double from the float values.
    for (float side : {1.0f, -1.0f}) {
      const Vec3<float> from = offset_origin(local.p, local.normal, side, local.delta);
      const Vec3<double> fd = Vec3<double>{from.x, from.y, from.z} - cd;
      if (side > 0)
        EXPECT_GT(dot(fd, fd), double(r2)) << "ratio " << ratio << " dist " << dist;
      else
        EXPECT_LT(dot(fd, fd), double(r2)) << "ratio " << ratio << " dist " << dist;
    }
  }
  std::printf(
      "%d hits: normal off double by %.3g at most relative to the sphere, %.3g from o + t d\n",
      hits, worst_local, worst_along);
  EXPECT_GT(hits, 8000);
  EXPECT_GT(worst_along, 100 * worst_local) << "the case that showed the defect";
}

// Camera rays along a plane (issue 39): a generated cloud whose horizon falls on a pixel row
// (100x75: the row at y = 0.12 is exactly level). Float's camera rays of that row meet the
// ground about 3.4e8 away where double's miss it: no formula on float's ray tells, its
// direction is off by more than its angle to the plane. Auto now takes double there, and
// keeps float one row away from it.
int far_hits_double_denies(const Scene& s, Precision p) {
  RenderOptions opt;
  opt.precision = p;
  opt.threads = 2;
  RenderOptions dbl = opt;
  dbl.precision = Precision::dbl;
  const PrimaryResult a = render_primary_with_ids(s, opt), b = render_primary_with_ids(s, dbl);
  int wrong = 0;
  for (std::size_t k = 0; k < a.id.size(); ++k) wrong += a.id[k] != b.id[k] && a.t[k] > 1e7f;
  return wrong;
}

TEST(FloatEnvelope, RegressionCameraRaysAlongAPlane) {
  generate::Options g;
  g.nx = 100, g.ny = 75;
  const Scene s = from(json::parse(generate::scene_json(g)));
  EXPECT_GT(far_hits_double_denies(s, Precision::exact), 0) << "the case no longer shows";
  const PrecisionChoice c = choose_precision(s);
  EXPECT_EQ(c.precision, Precision::dbl) << c.reason;
  EXPECT_EQ(far_hits_double_denies(s, Precision::automatic), 0);
  std::printf("exact: %d camera rays hit the ground beyond 1e7 where double misses; auto: %s\n",
              far_hits_double_denies(s, Precision::exact), c.reason.c_str());
  // One row more: the horizon between rows, float's rays meet the ground where double's do.
  g.ny = 76;
  const Scene between = from(json::parse(generate::scene_json(g)));
  EXPECT_EQ(far_hits_double_denies(between, Precision::exact), 0);
  EXPECT_EQ(choose_precision(between).precision, Precision::exact);
  // An eye in the plane meets it at t = 0 only, at any angle: float holds (Extremes'
  // parallel-rays case, the middle row exactly level).
  const Scene in_plane = parse_scene(R"json({
    "camera": {"type": "pinhole", "position": [0, 0, 0], "direction": [0, 0, -1], "distance": 1,
               "resolution": [63, 63], "bounds": [-1, 1, -1, 1]},
    "lights": [{"position": [10, 20, 30], "intensity": 1}],
    "objects": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0]},
                {"type": "sphere", "center": [0, 0.2, -4], "radius": 0.5}]})json",
                                     "eye-in-plane");
  EXPECT_EQ(choose_precision(in_plane).precision, Precision::exact);
  // An orthographic view 1e-8 off the plane: its rays are (0, 0, -1) in the camera's basis and
  // d.n the normal's component rounded once, so float meets the ground 1e8 away as double does.
  const Scene ortho = parse_scene(R"json({
    "camera": {"type": "orthographic", "position": [0, 1, 5], "direction": [0, -1e-8, -1],
               "resolution": [64, 64], "bounds": [-2, 2, -0.5, 3]},
    "lights": [{"position": [-10, 20, 10], "intensity": 0.7, "ambient": 0.15}],
    "objects": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0]},
                {"type": "sphere", "center": [0, 1, -10], "radius": 1}]})json",
                                  "orthographic-along-a-plane");
  EXPECT_EQ(choose_precision(ortho).precision, Precision::exact);
  const Image truth = testing::render_with(ortho, 1, Precision::dbl);
  EXPECT_EQ(off(ortho, Precision::exact, truth), 0);
}

// Multi-bounce chaos (issue 39): a dense cloud of mirrors (1024 spheres, reflect 0.9,
// max_depth 6) puts 2.3% of pixels more than 2/255 off double in exact float, at sizes well
// inside the envelope; auto picked float. It now measures a sample of rows in both and takes
// double. The same cloud at reflect 0.5 and max_depth 3 (0.10% off) keeps float.
Scene mirror_cloud(double reflect, int depth) {
  generate::Options g;
  g.nx = 160, g.ny = 120;
  g.reflect = reflect;
  json j = json::parse(generate::scene_json(g));
  j["max_depth"] = depth;
  return from(j);
}

TEST(FloatEnvelope, RegressionMultiBounceChaos) {
  const Scene chaos = mirror_cloud(0.9, 6);
  const Image truth = testing::render_with(chaos, 0, Precision::dbl, 2);
  const double exact = off(chaos, Precision::exact, truth);
  std::printf("mirror cloud, reflect 0.9, depth 6: exact %.3f%% off, auto %s\n", 100 * exact,
              choose_precision(chaos).reason.c_str());
  EXPECT_GT(exact, kBudget) << "the case no longer shows";
  EXPECT_EQ(choose_precision(chaos).precision, Precision::dbl);
  EXPECT_LE(off(chaos, Precision::automatic, truth), kBudget);

  const Scene calm = mirror_cloud(0.5, 3);
  const Image calm_truth = testing::render_with(calm, 0, Precision::dbl, 2);
  EXPECT_LE(off(calm, Precision::exact, calm_truth), kBudget);
  EXPECT_EQ(choose_precision(calm).precision, Precision::exact) << choose_precision(calm).reason;
}

}  // namespace
}  // namespace lancer
