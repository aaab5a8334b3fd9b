// lancer flux (issue 6): the flux profile against the independent oracle, the reference's path
// log against paths worked out by hand, the plane check, the recorder leaving images alone, and
// the figures.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "lancer/error.hpp"
#include "lancer/flux.hpp"
#include "lancer/image.hpp"
#include "lancer/plot.hpp"
#include "lancer/prepared.hpp"
#include "lancer/reference.hpp"

namespace lancer {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using Segment = reference::PathLog::Segment;

const std::string kSource = LANCER_SOURCE_DIR;
const std::string kFluxScene = kSource + "/scenes/flux2d.json";

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

struct Run {
  int status = -1;
  std::string out, err;
};
// Runs a shell command, capturing stdout and stderr.
Run run(const std::string& command) {
  const std::string err_path = ::testing::TempDir() + "/flux_test_stderr.txt";
  Run r;
  std::FILE* p = popen((command + " 2>" + err_path).c_str(), "r");
  if (!p) return r;
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  r.err = read_file(err_path);
  return r;
}

struct Csv {
  std::vector<double> x, flux;
};
Csv parse_csv(const std::string& text) {
  Csv c;
  std::istringstream in(text);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "x,flux");
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    const auto comma = line.find(',');
    c.x.push_back(std::stod(line.substr(0, comma)));
    c.flux.push_back(std::stod(line.substr(comma + 1)));
  }
  return c;
}

// A fresh folder for one test's files.
std::string temp_dir(const std::string& name) {
  const fs::path d = fs::path(::testing::TempDir()) / ("lancer_flux_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d.string();
}

// ---------------------------------------------------------------------------------------------
// (a) The flux of scenes/flux2d.json against the oracle.

TEST(FluxProfile, AgreesWithOracle) {
  const Run oracle = run(std::string(LANCER_ORACLE) + " " + kFluxScene + " --flux");
  ASSERT_EQ(oracle.status, 0) << oracle.err;
  const Csv want = parse_csv(oracle.out);
  ASSERT_EQ(want.x.size(), 100u);

  const flux::FluxScene fs = flux::load_flux_scene(kFluxScene);
  const flux::Profile got = flux::flux_profile(fs.scene);
  ASSERT_EQ(got.x.size(), want.x.size());
  int lit = 0;
  for (std::size_t i = 0; i < got.x.size(); ++i) {
    EXPECT_EQ(got.x[i], want.x[i]) << "i = " << i;  // the same formula, in double
    EXPECT_NEAR(got.flux[i], want.flux[i], 1e-4) << "x = " << got.x[i];
    lit += got.flux[i] > 0;
  }
  // The text's figure: dark where the rays pass between the spheres, lit where they hit.
  EXPECT_GT(lit, 40);
  EXPECT_LT(lit, 80);
  EXPECT_EQ(got.rays.camera, 100u);
}

TEST(FluxProfile, CliPrintsTheProfile) {
  const flux::Profile p = flux::flux_profile(flux::load_flux_scene(kFluxScene).scene);
  const Run r = run(std::string(LANCER_CLI) + " flux " + kFluxScene);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, flux::profile_csv(p));

  const std::string dir = temp_dir("csv");
  const Run w = run(std::string(LANCER_CLI) + " flux " + kFluxScene + " --csv " + dir + "/f.csv");
  ASSERT_EQ(w.status, 0) << w.err;
  EXPECT_EQ(read_file(dir + "/f.csv"), flux::profile_csv(p));
  const Csv c = parse_csv(read_file(dir + "/f.csv"));
  ASSERT_EQ(c.x.size(), 100u);
  EXPECT_DOUBLE_EQ(c.x[0], 0.05);  // xmin + 0.5 (xmax - xmin) / nx
  EXPECT_DOUBLE_EQ(c.x[99], 9.95);
}

// ---------------------------------------------------------------------------------------------
// (b) Recorded paths against hand-computed ones.
//
// A row of 3 orthographic rays from (x, 0, 0) along +y at x = -2, 0, 2 (bounds [-3, 3]), and a
// sphere of centre (1, 5, 0) and radius 2: the ray at x = -2 passes 3 from the centre and
// misses; the rays at x = 0 and x = 2 pass 1 from it and hit at y = 5 - sqrt(3).

json row_scene() {
  return {{"camera",
           {{"type", "orthographic"},
            {"position", {0, 0, 0}},
            {"direction", {0, 1, 0}},
            {"resolution", {3, 1}},
            {"bounds", {-3, 3, -0.5, 0.5}}}},
          {"lights", {{{"position", {1, 0, 0}}}}},
          {"objects", {{{"type", "sphere"}, {"center", {1, 5, 0}}, {"radius", 2}}}}};
}

const double kHitY = 5 - std::sqrt(3.0);

struct Recorded {
  flux::FluxScene scene;
  flux::RayPlane plane;
  flux::Paths paths;
};
Recorded record(const json& j) {
  Recorded r;
  r.scene = flux::parse_flux_scene(j.dump(), "test.json");
  r.plane = flux::ray_plane(r.scene.scene, r.scene.names);
  r.paths = flux::record_paths(r.scene.scene, r.plane);
  return r;
}

void expect_point(const Vec3<double>& got, double x, double y, double z, const char* what) {
  EXPECT_NEAR(got.x, x, 1e-9) << what;
  EXPECT_NEAR(got.y, y, 1e-9) << what;
  EXPECT_NEAR(got.z, z, 1e-9) << what;
}

void expect_segment(const Segment& s, Segment::Kind kind, bool hit, int depth, int pixel, int id) {
  EXPECT_EQ(s.kind, kind);
  EXPECT_EQ(s.hit, hit);
  EXPECT_EQ(s.depth, depth);
  EXPECT_EQ(s.pixel, pixel);
  EXPECT_EQ(s.sample, 0);
  EXPECT_EQ(s.id, id);
}

int count(const reference::PathLog& log, Segment::Kind kind, bool hit) {
  int n = 0;
  for (const Segment& s : log.segments) n += s.kind == kind && s.hit == hit;
  return n;
}

TEST(PathLog, OneSphereOneLight) {
  const Recorded r = record(row_scene());
  const auto& seg = r.paths.log.segments;
  ASSERT_EQ(seg.size(), 5u);  // a miss; two hits with one light ray each
  // Pixel 0: the miss, drawn miss_length along +y.
  expect_segment(seg[0], Segment::camera, false, 0, 0, -1);
  expect_point(seg[0].from, -2, 0, 0, "miss from");
  expect_point(seg[0].to, -2, r.paths.log.miss_length, 0, "miss to");
  // Pixels 1 and 2: the hit, then the light ray to (1, 0, 0), which faces away from the sphere.
  expect_segment(seg[1], Segment::camera, true, 0, 1, 0);
  expect_point(seg[1].from, 0, 0, 0, "camera 1 from");
  expect_point(seg[1].to, 0, kHitY, 0, "camera 1 hit");
  expect_segment(seg[2], Segment::light, false, 0, 1, 0);
  expect_point(seg[2].from, 0, kHitY, 0, "light 1 from");
  expect_point(seg[2].to, 1, 0, 0, "light 1 to");
  expect_segment(seg[3], Segment::camera, true, 0, 2, 0);
  expect_point(seg[3].to, 2, kHitY, 0, "camera 2 hit");
  expect_segment(seg[4], Segment::light, false, 0, 2, 0);
  expect_point(seg[4].from, 2, kHitY, 0, "light 2 from");
  // Hit points on the sphere's surface.
  for (int k : {1, 3}) {
    const Vec3<double> d = seg[k].to - Vec3<double>{1, 5, 0};
    EXPECT_NEAR(length(d), 2.0, 1e-12);
  }
  // The flux there: kd I cos = n . l with n = (-1, -sqrt 3, 0) / 2 at x = 0.
  const double l_len = std::hypot(1.0, kHitY);
  const double flux = (-1 * 1 + -std::sqrt(3.0) * -kHitY) / 2 / l_len;
  EXPECT_NEAR(r.paths.image.pixel(1, 0)[0], flux, 1e-6);
  EXPECT_NEAR(r.paths.image.pixel(2, 0)[0], flux, 1e-6);  // the mirror image about x = 1
  EXPECT_EQ(r.paths.image.pixel(0, 0)[0], 0.0f);
  EXPECT_EQ(r.paths.rays.camera, 3u);
  EXPECT_EQ(r.paths.rays.shadow, 2u);
  EXPECT_EQ(r.paths.rays.reflected, 0u);
}

// A second light at (-8, 3.25, 0) and a small sphere at (-4, 3.25, 0) of radius 0.5 between it
// and the hit at x = 0 (the line passes 0.009 from its centre); from the hit at x = 2 the light
// lies behind the big sphere itself. Both light rays to it are blocked: recorded with hit =
// true, left out of the diagram, and the flux is that of the first light alone.
TEST(PathLog, BlockedLightRaysAreNotDrawn) {
  json j = row_scene();
  j["lights"].push_back({{"position", {-8, 3.25, 0}}});
  j["objects"].push_back({{"type", "sphere"}, {"center", {-4, 3.25, 0}}, {"radius", 0.5}});
  const Recorded r = record(j);
  const auto& seg = r.paths.log.segments;
  ASSERT_EQ(seg.size(), 7u);
  EXPECT_EQ(count(r.paths.log, Segment::camera, true), 2);
  EXPECT_EQ(count(r.paths.log, Segment::camera, false), 1);
  EXPECT_EQ(count(r.paths.log, Segment::light, false), 2);
  EXPECT_EQ(count(r.paths.log, Segment::light, true), 2);
  for (const Segment& s : seg) {
    if (s.kind != Segment::light) continue;
    EXPECT_EQ(s.hit, s.id == 1) << "light " << s.id << " pixel " << s.pixel;
    if (s.id == 1) expect_point(s.to, -8, 3.25, 0, "blocked light");
  }
  // Same flux as with the first light only.
  const Recorded one = record(row_scene());
  for (int i = 0; i < 3; ++i) EXPECT_EQ(r.paths.image.pixel(i, 0)[0], one.paths.image.pixel(i, 0)[0]);

  // The diagram: two blue light rays, not four; grey ones for the blocked only when asked.
  auto lines_of = [](const plot::Drawing& d, plot::Color c) {
    int n = 0;
    for (const plot::Line& l : d.lines) n += l.color.r == c.r && l.color.g == c.g && l.color.b == c.b;
    return n;
  };
  const plot::Drawing d = flux::diagram(r.scene.scene, r.plane, r.paths.log);
  EXPECT_EQ(lines_of(d, plot::kBlue), 2);
  EXPECT_EQ(lines_of(d, plot::kRed), 3);  // two hits and the miss, cut at the edge
  EXPECT_EQ(lines_of(d, plot::kGrey), 1);  // the camera's row
  flux::DiagramOptions o;
  o.show_blocked = true;
  EXPECT_EQ(lines_of(flux::diagram(r.scene.scene, r.plane, r.paths.log, o), plot::kGrey), 3);
  o = {};
  o.hits_only = true;
  EXPECT_EQ(lines_of(flux::diagram(r.scene.scene, r.plane, r.paths.log, o), plot::kRed), 2);
  // Spheres and lights are drawn as circles: 2 spheres, 2 lights.
  EXPECT_EQ(d.circles.size(), 4u);
}

// The sphere mirrors (reflect 0.5, max_depth 1) and a plane y = -1 lies below the camera. At
// x = 0 the normal is n = (-1, -sqrt 3) / 2 and the ray (0, 1) leaves along
// r = d - 2 (d.n) n = (-sqrt 3 / 2, -1 / 2), reaching y = -1 after t = 2 (6 - sqrt 3), at
// x = 3 - 6 sqrt 3; from x = 2 it leaves mirrored, to x = 6 sqrt 3 - 1. Each plane hit casts
// its own light ray (depth 1) and, at max_depth, no further reflection.
TEST(PathLog, ReflectedRaysToAPlane) {
  json j = row_scene();
  j["max_depth"] = 1;
  j["objects"][0]["material"] = {{"reflect", 0.5}};
  j["objects"].push_back({{"type", "plane"}, {"point", {0, -1, 0}}, {"normal", {0, 1, 0}}});
  const Recorded r = record(j);
  const auto& seg = r.paths.log.segments;
  ASSERT_EQ(seg.size(), 9u);
  expect_segment(seg[0], Segment::camera, false, 0, 0, -1);  // the plane is behind it
  const double s3 = std::sqrt(3.0);
  const double plane_x[3] = {0, 3 - 6 * s3, 6 * s3 - 1};
  for (int pixel = 1; pixel <= 2; ++pixel) {
    const Segment* p = &seg[1 + 4 * (pixel - 1)];
    const double x = pixel == 1 ? 0 : 2;
    expect_segment(p[0], Segment::camera, true, 0, pixel, 0);
    expect_point(p[0].to, x, kHitY, 0, "sphere hit");
    expect_segment(p[1], Segment::light, false, 0, pixel, 0);
    expect_segment(p[2], Segment::reflected, true, 1, pixel, 1);  // object 1: the plane
    expect_point(p[2].from, x, kHitY, 0, "reflected from");
    expect_point(p[2].to, plane_x[pixel], -1, 0, "plane hit");
    expect_segment(p[3], Segment::light, false, 1, pixel, 0);
    expect_point(p[3].from, plane_x[pixel], -1, 0, "light from the plane");
    expect_point(p[3].to, 1, 0, 0, "light");
  }
  EXPECT_EQ(r.paths.rays.reflected, 2u);
  EXPECT_EQ(r.paths.rays.shadow, 4u);
}

// ---------------------------------------------------------------------------------------------
// (c) Scenes whose rays leave the plane are refused, naming the place.

std::string refusal(const json& j) {
  try {
    const flux::FluxScene fs = flux::parse_flux_scene(j.dump(), "test.json");
    flux::ray_plane(fs.scene, fs.names);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

json flux2d() { return json::parse(read_file(kFluxScene)); }

TEST(RayPlane, Flux2dIsTheZPlane) {
  const flux::FluxScene fs = flux::load_flux_scene(kFluxScene);
  const flux::RayPlane p = flux::ray_plane(fs.scene, fs.names);
  expect_point(p.origin, 0, 0, 0, "origin");
  expect_point(p.along, 1, 0, 0, "u");
  expect_point(p.forward, 0, 1, 0, "-w");
  expect_point(p.normal, 0, 0, 1, "v");
  EXPECT_EQ(refusal(flux2d()), "");
}

TEST(RayPlane, RefusesWhatLeavesThePlane) {
  json j = flux2d();
  j["objects"][1]["center"][2] = 0.5;
  EXPECT.find("objects[1].center"), std::string::npos);
}

}  // namespace
}  // namespace lancer
