// lancer flux (issue 6): the flux profile against the independent oracle, the reference's path
// log against paths worked out by hand, the plane check, the recorder leaving images alone, and
// the figures.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

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

struct Ran {
  int status = -1;
  std::string out, err;
};
// Runs a shell command, capturing stdout and stderr.
Ran run(const std::string& command) {
  // Per process: ctest runs this file's tests as processes side by side, and a shared file
  // handed one test another's stderr (RayPlane.CliRefusesWithStatus2AndNoFile, seen once).
  const std::string err_path =
      ::testing::TempDir() + "/flux_test_stderr_" + std::to_string(getpid()) + ".txt";
  Ran r;
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
  const Ran oracle = run(std::string(LANCER_ORACLE) + " " + kFluxScene + " --flux");
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
  const Ran r = run(std::string(LANCER_CLI) + " flux " + kFluxScene);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, flux::profile_csv(p));

  const std::string dir = temp_dir("csv");
  const Ran w = run(std::string(LANCER_CLI) + " flux " + kFluxScene + " --csv " + dir + "/f.csv");
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
  for (int i = 0; i < 3; ++i)
    EXPECT_EQ(r.paths.image.pixel(i, 0)[0], one.paths.image.pixel(i, 0)[0]);

  // The diagram: two light rays that reach their light, not four; the blocked ones only when
  // asked.
  auto segments_of = [](const plot::Chart& d, const std::string& name) {
    for (const plot::Series& s : d.series)
      if (s.name == name) return int(s.x.size() / 2);
    return 0;
  };
  const plot::Chart d = flux::diagram(r.scene.scene, r.plane, r.paths.log);
  EXPECT_EQ(segments_of(d, "rays that reach a light"), 2);
  EXPECT_EQ(segments_of(d, "camera and reflected rays"), 3);  // two hits and the miss, cut
  EXPECT_EQ(segments_of(d, "camera row"), 1);
  EXPECT_EQ(segments_of(d, "blocked rays to lights"), 0);
  flux::DiagramOptions o;
  o.show_blocked = true;
  EXPECT_EQ(
      segments_of(flux::diagram(r.scene.scene, r.plane, r.paths.log, o), "blocked rays to lights"),
      2);
  o = {};
  o.hits_only = true;
  EXPECT_EQ(segments_of(flux::diagram(r.scene.scene, r.plane, r.paths.log, o),
                        "camera and reflected rays"),
            2);
  // 2 spheres as circles, 2 lights as points, a legend entry each.
  EXPECT_EQ(d.circles.size(), 2u);
  for (const plot::Series& s : d.series) {
    EXPECT_FALSE(s.name.empty());
    if (s.name == "lights") {
      EXPECT_EQ(s.x.size(), 2u);
    }
  }
  EXPECT_TRUE(d.equal_aspect);
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
  auto refused = [](json j, const std::string& place) {
    const std::string why = refusal(j);
    EXPECT_EQ(why.rfind(place + ":", 0), 0u) << "wanted " << place << ", got: " << why;
  };
  json j = flux2d();
  j["objects"][1]["center"][2] = 0.5;
  refused(j, "objects[1].center");
  j = flux2d();
  j["lights"][2]["position"] = {0.5, 0.5, -1};
  refused(j, "lights[2].position");
  j = flux2d();
  j["objects"].push_back({{"type", "plane"}, {"point", {0, 9, 0}}, {"normal", {0, 1, 0.1}}});
  refused(j, "objects[4].normal");
  // A plane whose normal lies in the plane of the rays is fine: it crosses it in a line.
  j = flux2d();
  j["objects"].push_back({{"type", "plane"}, {"point", {0, 9, 3}}, {"normal", {0, -1, 0}}});
  EXPECT_EQ(refusal(j), "");
  // The camera: tilted so the rays leave z = 0 (its plane misses the sphere centres).
  j = flux2d();
  j["camera"]["direction"] = {0, 1, 0.2};
  refused(j, "objects[0].center");
  j = flux2d();
  j["camera"]["type"] = "pinhole";
  j["camera"]["distance"] = 1;
  refused(j, "camera.type");
  j = flux2d();
  j["camera"]["resolution"] = {100, 2};
  refused(j, "camera.resolution");
  j = flux2d();
  j["supersample"] = 2;
  refused(j, "supersample");
  // Within the tolerance (1e-9 of the scene's size): rounding, not a tilt.
  j = flux2d();
  j["objects"][1]["center"][2] = 1e-12;
  j["lights"][0]["position"][2] = -1e-12;
  EXPECT_EQ(refusal(j), "");
  // Off by more: refused.
  j["objects"][1]["center"][2] = 1e-6;
  refused(j, "objects[1].center");
}

TEST(RayPlane, CliRefusesWithStatus2AndNoFile) {
  const std::string dir = temp_dir("refuse");
  json j = flux2d();
  j["objects"][2]["center"][2] = 0.25;
  write_file(dir + "/tilted.json", j.dump());
  const Ran r = run(std::string(LANCER_CLI) + " flux " + dir + "/tilted.json --plot " + dir +
                    "/p.png --diagram " + dir + "/d.svg --csv " + dir + "/f.csv");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("objects[2].center"), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
  for (const char* f : {"/p.png", "/d.svg", "/f.csv"}) EXPECT_FALSE(fs::exists(dir + f)) << f;

  j = flux2d();
  j["camera"]["resolution"] = {100, 3};
  write_file(dir + "/rows.json", j.dump());
  const Ran rows = run(std::string(LANCER_CLI) + " flux " + dir + "/rows.json");
  EXPECT_EQ(rows.status, 2);
  EXPECT_NE(rows.err.find("camera.resolution"), std::string::npos) << rows.err;
}

// ---------------------------------------------------------------------------------------------
// (d) Recording changes nothing: the same bits and counts as render_rows.

template <class T>
void expect_recorder_changes_nothing(const Scene& scene, int row_begin, int row_end) {
  const PreparedScene<T> p = prepare<T>(scene);
  Image plain(scene.camera.nx, scene.camera.ny), recorded(scene.camera.nx, scene.camera.ny);
  RayCounts plain_counts, recorded_counts;
  reference::PathLog log;
  reference::render_rows(p, plain, row_begin, row_end, plain_counts);
  reference::render_rows_recorded(p, recorded, row_begin, row_end, recorded_counts, log);
  ASSERT_EQ(plain.rgb.size(), recorded.rgb.size());
  EXPECT_EQ(std::memcmp(plain.rgb.data(), recorded.rgb.data(), plain.rgb.size() * sizeof(float)),
            0);
  EXPECT_TRUE(plain_counts == recorded_counts);
  // One segment per camera, reflected and light ray.
  EXPECT_EQ(log.segments.size(), recorded_counts.total());
}

TEST(PathLog, RecorderChangesNothing) {
  for (const char* name : {"flux2d", "lorenzi-diffuse", "lorenzi-shadows", "lorenzi-reflections"}) {
    SCOPED_TRACE(name);
    const Scene s = load_scene(kSource + "/scenes/" + name + ".json");
    const int r0 = s.camera.ny / 2, r1 = std::min(s.camera.ny, r0 + 3);
    expect_recorder_changes_nothing<float>(s, r0, r1);
    expect_recorder_changes_nothing<double>(s, r0, r1);
  }
  // And the recorded flux scene is the profile's render.
  const flux::FluxScene fs = flux::load_flux_scene(kFluxScene);
  const flux::Paths paths = flux::record_paths(fs.scene, flux::ray_plane(fs.scene, fs.names));
  const flux::Profile profile = flux::flux_profile(fs.scene);
  for (int i = 0; i < fs.scene.camera.nx; ++i) {
    const float* px = paths.image.pixel(i, 0);
    EXPECT_EQ((double(px[0]) + double(px[1]) + double(px[2])) / 3, profile.flux[i]);
  }
  EXPECT_TRUE(paths.rays == profile.rays);
}

// ---------------------------------------------------------------------------------------------
// Figures.

TEST(Plot, NiceTicks) {
  const plot::Ticks t = plot::nice_ticks(-0.5, 10.5, 7);
  EXPECT_EQ(t.values, (std::vector<double>{0, 2, 4, 6, 8, 10}));
  EXPECT_EQ(t.decimals, 0);
  const plot::Ticks f = plot::nice_ticks(-0.07, 1.47, 6);
  ASSERT_FALSE(f.values.empty());
  EXPECT_NEAR(f.values.front(), 0, 1e-12);
  EXPECT_NEAR(f.values.back(), 1.4, 1e-12);
  EXPECT_EQ(f.decimals, 1);
}

TEST(Plot, ClipSegment) {
  double ax = -5, ay = 5, bx = 15, by = 5;
  ASSERT_TRUE(plot::clip_segment(ax, ay, bx, by, 0, 0, 10, 10));
  EXPECT_DOUBLE_EQ(ax, 0);
  EXPECT_DOUBLE_EQ(bx, 10);
  ax = -5, ay = 20, bx = 15, by = 20;
  EXPECT_FALSE(plot::clip_segment(ax, ay, bx, by, 0, 0, 10, 10));
}

// Point labels never overlap each other and stay in the frame, however crowded the points.
TEST(Plot, LabelsNeverCollideOrLeaveTheFrame) {
  plot::Chart c;
  c.title = "crowded";
  c.x.label = "x (units)";
  c.y.label = "y (units)";
  for (int k = 0; k < 3; ++k) {
    plot::Series s;
    s.name = "series " + std::to_string(k);
    s.color = plot::palette(k);
    for (int i = 0; i < 12; ++i) {
      // Points nearly on top of each other, and some on the edges of the range.
      s.x.push_back(i < 6 ? 1 + 0.001 * i : 10 * (i - 6));
      s.y.push_back(i < 6 ? 1 + 0.001 * k : 5 * k);
      s.labels.push_back("label " + std::to_string(k) + "." + std::to_string(i));
    }
    c.series.push_back(s);
  }
  const std::vector<plot::LabelBox> boxes = plot::label_boxes(c);
  ASSERT_EQ(boxes.size(), 36u);
  int placed = 0;
  for (std::size_t a = 0; a < boxes.size(); ++a) {
    const plot::LabelBox& b = boxes[a];
    if (b.x0 > b.x1) continue;  // left out: no free place
    ++placed;
    EXPECT_GE(b.x0, 0);
    EXPECT_GE(b.y0, 0);
    EXPECT_LE(b.x1, c.width);
    EXPECT_LE(b.y1, c.height);
    for (std::size_t o = a + 1; o < boxes.size(); ++o) {
      const plot::LabelBox& q = boxes[o];
      if (q.x0 > q.x1) continue;
      EXPECT_FALSE(b.x0 < q.x1 && q.x0 < b.x1 && b.y0 < q.y1 && q.y0 < b.y1)
          << "labels " << a << " and " << o << " overlap";
    }
  }
  EXPECT_GE(placed, 30);
}

// One drawing, three formats: PNG of the asked size with the series' colour in it, SVG and PDF
// with their headers; log axes drop non-positive values instead of failing.
TEST(Plot, WritesPngSvgPdf) {
  const std::string dir = temp_dir("chart");
  plot::Chart c;
  c.width = 400, c.height = 300;
  c.title = "scaling";
  c.x.label = "spheres";
  c.y.label = "Mrays/s";
  c.x.scale = c.y.scale = plot::Scale::log10;
  plot::Series s;
  s.name = "lancer";
  s.color = plot::kRed;
  s.mark = plot::Mark::line;
  s.line_width = 6;
  s.x = {0, 1, 10, 100, 1000};  // 0 has no logarithm: left out
  s.y = {5, 100, 100, 100, 100};
  c.series.push_back(s);
  plot::write_chart(c, dir + "/c.png");
  plot::write_chart(c, dir + "/c.svg");
  plot::write_chart(c, dir + "/c.pdf");
  const Image im = read_image(dir + "/c.png");
  ASSERT_EQ(im.nx, 400);
  ASSERT_EQ(im.ny, 300);
  int red = 0;
  for (int j = 0; j < im.ny; ++j)
    for (int i = 0; i < im.nx; ++i) {
      const float* p = im.pixel(i, j);
      red += p[0] > 0.8f && p[1] < 0.2f && p[2] < 0.2f;
    }
  EXPECT_GT(red, 300);  // a 6-point line across most of the plot
  const std::string svg = read_file(dir + "/c.svg");
  EXPECT_EQ(svg.rfind("<?xml", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_EQ(read_file(dir + "/c.pdf").rfind("%PDF", 0), 0u);
}

TEST(Plot, ChartFromCsv) {
  const plot::Chart c =
      plot::chart_from_csv("engine,spheres,mrays\nlancer,1,10\nembree,1,5\nlancer,10,8\n", "s.csv",
                           "spheres", "mrays", "engine", plot::Mark::line_points);
  ASSERT_EQ(c.series.size(), 2u);
  EXPECT_EQ(c.series[0].name, "lancer");
  EXPECT_EQ(c.series[0].x, (std::vector<double>{1, 10}));
  EXPECT_EQ(c.series[1].y, (std::vector<double>{5}));
  EXPECT_FALSE(c.series[0].color == c.series[1].color);
  try {
    plot::chart_from_csv("a,b\n1,x\n", "s.csv", "a", "b", "", plot::Mark::points);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "s.csv:2: b: 'x' is not a finite number");
  }
  EXPECT_THROW(plot::chart_from_csv("a,b\n1,2\n", "s.csv", "a", "c", "", plot::Mark::points),
               InputError);
}

// Axis labels carry the unit the header gives, written out or read from the name's suffix; a
// column is named with or without its unit.
TEST(Plot, LabelsCarryUnits) {
  EXPECT_EQ(plot::column_label("mrays_per_s"), "Mrays/s");
  EXPECT_EQ(plot::column_label("build_s"), "build (s)");
  EXPECT_EQ(plot::column_label("frame_ms"), "frame (ms)");
  EXPECT_EQ(plot::column_label("psnr_db"), "psnr (dB)");
  EXPECT_EQ(plot::column_label("time [us]"), "time [us]");
  EXPECT_EQ(plot::column_label("spheres"), "spheres");
  const plot::Chart c = plot::chart_from_csv("spheres,time (s)\n1,0.5\n2,0.75\n", "s.csv",
                                             "spheres", "time", "", plot::Mark::points);
  EXPECT_EQ(c.x.label, "spheres");
  EXPECT_EQ(c.y.label, "time (s)");
  EXPECT_EQ(c.series.at(0).y, (std::vector<double>{0.5, 0.75}));
}

TEST(Figures, CliWritesPlotAndDiagram) {
  const std::string dir = temp_dir("figures");
  const Ran r = run(std::string(LANCER_CLI) + " flux " + kFluxScene + " --plot " + dir +
                    "/plot.png --diagram " + dir + "/diagram.png");
  ASSERT_EQ(r.status, 0) << r.err;
  const Image plot_im = read_image(dir + "/plot.png");
  EXPECT_EQ(plot_im.nx, 760);
  EXPECT_EQ(plot_im.ny, 500);
  const Image diag = read_image(dir + "/diagram.png");
  EXPECT_EQ(diag.nx, 800);

  const Ran s = run(std::string(LANCER_CLI) + " flux " + kFluxScene + " --plot " + dir +
                    "/plot.svg --diagram " + dir + "/diagram.pdf");
  ASSERT_EQ(s.status, 0) << s.err;
  const std::string svg = read_file(dir + "/plot.svg");
  EXPECT_EQ(svg.rfind("<?xml", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_EQ(read_file(dir + "/diagram.pdf").rfind("%PDF", 0), 0u);

  // The diagram's data: as many light-ray segments as light rays that reached their light.
  const flux::FluxScene fs = flux::load_flux_scene(kFluxScene);
  const flux::RayPlane plane = flux::ray_plane(fs.scene, fs.names);
  const flux::Paths paths = flux::record_paths(fs.scene, plane);
  int reached = 0;
  for (const Segment& seg : paths.log.segments) reached += seg.kind == Segment::light && !seg.hit;
  const plot::Chart d = flux::diagram(fs.scene, plane, paths.log);
  int drawn = 0;
  for (const plot::Series& ser : d.series)
    if (ser.name == "rays that reach a light") drawn = int(ser.x.size() / 2);
  EXPECT_EQ(drawn, reached);

  // A bad extension is refused before any work.
  const Ran bad =
      run(std::string(LANCER_CLI) + " flux " + kFluxScene + " --plot " + dir + "/plot.nope");
  EXPECT_EQ(bad.status, 2);
  EXPECT_NE(bad.err.find("--plot"), std::string::npos) << bad.err;
}

// Each value in the shortest text that reads back the same double: 0.05, not %.17g's
// 0.050000000000000003.
TEST(FluxCsv, ShortestTextThatReadsBack) {
  flux::Profile p;
  p.x = {0.05, 0.1 + 0.2, -9.95, 1e-300};
  p.flux = {1.0 / 3, 0, 0.8759077191352844, 2.5};
  const std::string csv = flux::profile_csv(p);
  EXPECT_EQ(csv,
            "x,flux\n0.05,0.3333333333333333\n0.30000000000000004,0\n-9.95,0.8759077191352844\n"
            "1e-300,2.5\n");
  std::istringstream in(csv);
  std::string line;
  std::getline(in, line);
  for (std::size_t k = 0; std::getline(in, line); ++k) {
    const std::size_t comma = line.find(',');
    EXPECT_EQ(std::strtod(line.substr(0, comma).c_str(), nullptr), p.x[k]) << line;
    EXPECT_EQ(std::strtod(line.substr(comma + 1).c_str(), nullptr), p.flux[k]) << line;
  }
}

}  // namespace
}  // namespace lancer
