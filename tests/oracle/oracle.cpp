// lancer_oracle: a plain, double-precision reference renderer for the scene model
// (docs/scene-format.md).
//
// It is written from the contract alone, independently of the engine in src/, so that comparing
// the two catches bugs in either. It favours the obvious formula over the fast one: recursion,
// one ray at a time, the textbook sphere quadratic, std::pow for the specular power.
//
//   lancer_oracle SCENE.json OUT.pfm [--supersample S] [--resolution NXxNY]
//   lancer_oracle SCENE.json [OUT.pfm] --flux     (prints row 0 as "x,flux" CSV, writes no file)
//   lancer_oracle --self-check                    (closed-form checks of the oracle itself)

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <initializer_list>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "oracle_model.hpp"

namespace {

using nlohmann::json;
using namespace oracle;

// ---------------------------------------------------------------------------------------------
// Tracing, step by step as in the contract's "Tracing" section.

// Smallest t > epsilon where the ray meets the object, if any.
// Moller-Trumbore (a different test from the engine's), edges included.
std::optional<double> intersect_triangle(const Object& o, Vec origin, Vec dir, double epsilon) {
  const Vec e1 = o.v[1] - o.v[0], e2 = o.v[2] - o.v[0];
  const Vec pv = cross(dir, e2);
  const double det = dot(e1, pv);
  if (det == 0) return std::nullopt;
  const Vec tv = origin - o.v[0];
  const double u = dot(tv, pv) / det;
  const Vec qv = cross(tv, e1);
  const double v = dot(dir, qv) / det;
  if (u < 0 || v < 0 || u + v > 1) return std::nullopt;
  const double t = dot(e2, qv) / det;
  if (t > epsilon) return t;
  return std::nullopt;
}

// The textbook quadratic in the plane across the axis, then the two cap planes.
std::optional<double> intersect_cylinder(const Object& o, Vec origin, Vec dir, double epsilon) {
  const Vec axis = normalize(o.v[1] - o.v[0]);
  const double h = length(o.v[1] - o.v[0]);
  const Vec f = origin - o.v[0];
  const Vec fp = f - dot(f, axis) * axis, dp = dir - dot(dir, axis) * axis;
  std::optional<double> best;
  auto take = [&](double t) {
    if (t > epsilon && (!best || t < *best)) best = t;
  };
  const double a = dot(dp, dp), b = 2 * dot(fp, dp), c = dot(fp, fp) - o.radius * o.radius;
  const double disc = b * b - 4 * a * c;
  if (a > 0 && disc >= 0) {
    for (double t : {(-b - std::sqrt(disc)) / (2 * a), (-b + std::sqrt(disc)) / (2 * a)}) {
      const double s = dot(f + t * dir, axis);
      if (s >= 0 && s <= h) take(t);
    }
  }
  const double da = dot(dir, axis);
  if (o.caps && da != 0)
    for (double s : {0.0, h}) {
      const double t = (s - dot(f, axis)) / da;
      const Vec q = f + t * dir - s * axis;
      if (dot(q, q) <= o.radius * o.radius) take(t);
    }
  return best;
}

// The cylinder's geometric normal at p: a cap's where p lies in its plane (within rounding) and
// inside its disc, else the side's.
Vec cylinder_normal(const Object& o, Vec p) {
  const Vec axis = normalize(o.v[1] - o.v[0]);
  const double h = length(o.v[1] - o.v[0]);
  const double s = dot(p - o.v[0], axis);
  const Vec radial = (p - o.v[0]) - s * axis;
  const double tol = 1e-9 * (h + o.radius + length(p));
  if (o.caps && length(radial) < o.radius * (1 - 1e-9)) {
    if (std::fabs(s) <= tol) return -axis;
    if (std::fabs(s - h) <= tol) return axis;
  }
  return normalize(radial);
}

std::optional<double> intersect(const Object& o, Vec origin, Vec dir, double epsilon) {
  if (o.shape == Shape::kTriangle) return intersect_triangle(o, origin, dir, epsilon);
  if (o.shape == Shape::kCylinder) return intersect_cylinder(o, origin, dir, epsilon);
  if (o.shape == Shape::kSphere) {
    // Textbook quadratic with a = 1 (dir is unit length): t^2 + b t + c = 0.
    Vec f = origin - o.center;
    double b = 2 * dot(f, dir);
    double c = dot(f, f) - o.radius * o.radius;
    double disc = b * b - 4 * c;
    if (disc < 0) return std::nullopt;
    double root = std::sqrt(disc);
    double t0 = (-b - root) / 2;
    double t1 = (-b + root) / 2;
    if (t0 > epsilon) return t0;
    if (t1 > epsilon) return t1;
    return std::nullopt;
  }
  double denom = dot(dir, o.normal);
  if (denom == 0) return std::nullopt;
  double t = dot(o.center - origin, o.normal) / denom;
  if (t > epsilon) return t;
  return std::nullopt;
}

struct Hit {
  double t;
  const Object* object;
};

// Closest hit; on an exact tie the object listed first wins.
std::optional<Hit> closest_hit(const Scene& s, Vec origin, Vec dir) {
  std::optional<Hit> best;
  for (const Object& o : s.objects) {
    std::optional<double> t = intersect(o, origin, dir, s.epsilon);
    if (t && (!best || *t < best->t)) best = Hit{*t, &o};
  }
  return best;
}

// The share of a light that reaches p: the product of `transmit` over every object whose
// nearest hit beyond epsilon lies before the light, each object once. 0 if any is opaque.
double transmittance(const Scene& s, Vec p, Vec to_light, double light_distance) {
  double product = 1;
  for (const Object& o : s.objects) {
    std::optional<double> t = intersect(o, p, to_light, s.epsilon);
    if (t && *t < light_distance) product *= o.material.transmit;
  }
  return product;
}

Rgb trace(const Scene& s, Vec origin, Vec dir, int depth) {
  std::optional<Hit> hit = closest_hit(s, origin, dir);
  if (!hit) return depth == 0 ? s.background : s.environment;

  const Object& o = *hit->object;
  const Material& m = o.material;
  Vec p = origin + hit->t * dir;
  Vec geometric = o.normal;
  if (o.shape == Shape::kSphere) {  // (P - C) / r, divided as written rather than normalised
    Vec d = p - o.center;
    geometric = {d.x / o.radius, d.y / o.radius, d.z / o.radius};
  }
  if (o.shape == Shape::kCylinder) geometric = cylinder_normal(o, p);
  Vec n = dot(geometric, dir) > 0 ? -geometric : geometric;
  Vec view = -dir;

  // Per channel: lights are colours.
  Rgb ambient, diffuse, specular;
  for (const Light& light : s.lights) {
    ambient = ambient + m.ka * light.ambient;
    Vec to_light = light.position - p;
    double light_distance = length(to_light);
    Vec l = normalize(to_light);
    double share = transmittance(s, p, l, light_distance);
    if (share == 0) continue;
    Rgb arriving = share * light.intensity;
    diffuse = diffuse + (m.kd * std::max(0.0, dot(n, l))) * arriving;
    Vec half = l + view;
    if (!is_zero(half)) {
      Vec h = normalize(half);
      specular = specular + (m.ks * std::pow(std::max(0.0, dot(n, h)), m.shininess)) * arriving;
    }
  }
  Rgb local = m.color * (ambient + diffuse + specular);

  Vec r = dir - 2 * dot(dir, n) * n;  // the mirror direction, for reflection and TIR
  if (depth < s.max_depth && m.reflect > 0) {
    local = local + m.reflect * trace(s, p, normalize(r), depth + 1);
  }
  if (depth < s.max_depth && m.transmit > 0) {
    // Snell-Descartes. Entering when the ray meets the geometric normal's side.
    bool entering = dot(geometric, dir) < 0;
    double eta = entering ? 1 / m.ior : m.ior;
    double c = -dot(dir, n);
    double k = 1 - eta * eta * (1 - c * c);
    Vec t = k >= 0 ? eta * dir + (eta * c - std::sqrt(k)) * n : r;  // k < 0: total reflection
    local = local + m.transmit * trace(s, p, normalize(t), depth + 1);
  }
  return local;
}

// ---------------------------------------------------------------------------------------------
// Camera and image

struct Basis {
  Vec u, v, w;
};

Basis camera_basis(Vec direction) {
  Basis b;
  b.w = normalize(-direction);
  Vec u{-b.w.z, 0, b.w.x};
  b.u = is_zero(u) ? Vec{1, 0, 0} : normalize(u);  // looking straight up or down
  b.v = cross(b.w, b.u);
  if (b.v.y < 0) {
    b.u = -b.u;
    b.v = -b.v;
  }
  return b;
}

// Radiance of pixel (i, j): mean of its s*s sub-samples.
Rgb render_pixel(const Scene& s, const Basis& basis, int i, int j) {
  const Camera& c = s.camera;
  const int n = s.supersample;
  Rgb sum;
  for (int b = 0; b < n; ++b) {
    for (int a = 0; a < n; ++a) {
      double x = c.xmin + (i + (a + 0.5) / n) * (c.xmax - c.xmin) / c.nx;
      double y = c.ymax - (j + (b + 0.5) / n) * (c.ymax - c.ymin) / c.ny;
      Vec origin = c.position;
      Vec dir = -basis.w;
      if (c.pinhole) {
        dir = normalize(x * basis.u + y * basis.v - c.distance * basis.w);
      } else {
        origin = c.position + x * basis.u + y * basis.v;
      }
      sum = sum + trace(s, origin, dir, 0);
    }
  }
  double count = n * n;
  return {sum.r / count, sum.g / count, sum.b / count};
}

// Row-major image, row 0 at the top. Renders rows [0, rows).
std::vector<Rgb> render(const Scene& s, int rows) {
  Basis basis = camera_basis(s.camera.direction);
  std::vector<Rgb> image;
  image.reserve(static_cast<size_t>(s.camera.nx) * rows);
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < s.camera.nx; ++i) image.push_back(render_pixel(s, basis, i, j));
  }
  return image;
}

void put_float_le(std::ostream& out, double value) {
  float f = static_cast<float>(value);
  uint32_t bits;
  std::memcpy(&bits, &f, sizeof bits);
  char bytes[4] = {static_cast<char>(bits & 0xff), static_cast<char>((bits >> 8) & 0xff),
                   static_cast<char>((bits >> 16) & 0xff), static_cast<char>((bits >> 24) & 0xff)};
  out.write(bytes, 4);
}

// PFM stores its bottom row first; "-1.0" declares little-endian floats.
bool write_pfm(const std::string& path, const std::vector<Rgb>& image, int nx, int ny) {
  std::ofstream out(path, std::ios::binary);
  out << "PF\n" << nx << " " << ny << "\n-1.0\n";
  for (int j = ny - 1; j >= 0; --j) {
    for (int i = 0; i < nx; ++i) {
      const Rgb& p = image[static_cast<size_t>(j) * nx + i];
      put_float_le(out, p.r);
      put_float_le(out, p.g);
      put_float_le(out, p.b);
    }
  }
  return static_cast<bool>(out);
}

void print_flux(const Scene& s) {
  std::vector<Rgb> row = render(s, 1);
  const Camera& c = s.camera;
  std::printf("x,flux\n");
  for (int i = 0; i < c.nx; ++i) {
    double x = c.xmin + (i + 0.5) * (c.xmax - c.xmin) / c.nx;
    const Rgb& p = row[i];
    std::printf("%.17g,%.17g\n", x, (p.r + p.g + p.b) / 3);
  }
}

// ---------------------------------------------------------------------------------------------
// Self-check: tiny scenes whose pixels have closed-form values.

Rgb pixel(const std::string& scene_json, int i, int j) {
  Scene s = parse_scene(json::parse(scene_json));
  return render(s, s.camera.ny)[static_cast<size_t>(j) * s.camera.nx + i];
}

bool expect(const char* name, Rgb got, Rgb want) {
  auto close = [](double a, double b) {
    return std::abs(a - b) <= 1e-12 * std::max(1.0, std::abs(b));
  };
  bool ok = close(got.r, want.r) && close(got.g, want.g) && close(got.b, want.b);
  std::printf("%s %s: got (%.17g, %.17g, %.17g) want (%.17g, %.17g, %.17g)\n", ok ? "ok  " : "FAIL",
              name, got.r, got.g, got.b, want.r, want.g, want.b);
  return ok;
}

Rgb grey(double v) { return {v, v, v}; }

int self_check() {
  // A unit sphere at the origin seen head-on from z = 5 by a 3x3 pinhole camera: the centre
  // ray is exactly -z and hits (0, 0, 1) where n = (0, 0, 1).
  const std::string head_on_camera =
      R"("camera": {"type": "pinhole", "position": [0, 0, 5], "direction": [0, 0, -1],
                    "distance": 1, "resolution": [3, 3], "bounds": [-0.3, 0.3, -0.3, 0.3]})";
  const std::string sphere =
      R"("objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1,
                      "material": {"color": [1, 0.5, 0.25], "kd": 0.6, "ks": 0.3, "shininess": 7}}])";
  bool ok = true;

  // Light on the axis: cos = 1, h = n, so kd*I + ks*I.
  ok &= expect("head-on light",
               pixel("{" + head_on_camera + "," + sphere +
                         R"(, "lights": [{"position": [0, 0, 10], "intensity": 0.7}]})",
                     1, 1),
               {0.9 * 0.7, 0.5 * 0.9 * 0.7, 0.25 * 0.9 * 0.7});

  // Light at (0, 3, 5): L - P = (0, 3, 4), cos = 0.8; l + view = (0, 0.6, 1.8),
  // n.h = 1.8 / sqrt(3.6).
  {
    double shade = 0.6 * 0.7 * 0.8 + 0.3 * 0.7 * std::pow(1.8 / std::sqrt(3.6), 7);
    ok &= expect("3-4-5 light",
                 pixel("{" + head_on_camera + "," + sphere +
                           R"(, "lights": [{"position": [0, 3, 5], "intensity": 0.7}]})",
                       1, 1),
                 {shade, 0.5 * shade, 0.25 * shade});
  }

  // A scene with no objects shows its background.
  ok &= expect("primary miss",
               pixel("{" + head_on_camera + R"(, "background": [0.1, 0.2, 0.3]})", 0, 0),
               {0.1, 0.2, 0.3});

  // Shadow: ground plane y = 0 below a sphere that sits between it and the light; only the
  // (never shadowed) ambient term remains: ka * Ia = 0.5 * 0.4.
  ok &= expect("shadow",
               pixel(R"({"camera": {"type": "orthographic", "position": [0, 5, 0],
                                    "direction": [0, -1, 0], "resolution": [1, 1],
                                    "bounds": [-0.1, 0.1, -0.1, 0.1]},
                        "lights": [{"position": [0, 10, 0], "ambient": 0.4}],
                        "objects": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 2, 0],
                                     "material": {"ka": 0.5}},
                                    {"type": "sphere", "center": [0, 7, 0], "radius": 0.5}]})",
                     0, 0),
               grey(0.2));

  // Mirror: kd = 0, a plane facing the orthographic camera; the reflected ray misses and
  // returns environment (0.2), not background (0.9): 0.5 * 0.2.
  ok &= expect("mirror to environment",
               pixel(R"({"camera": {"type": "orthographic", "position": [0, 0, 5],
                                    "direction": [0, 0, -1], "resolution": [1, 1],
                                    "bounds": [-1, 1, -1, 1]},
                        "background": 0.9, "environment": 0.2, "max_depth": 1,
                        "objects": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1],
                                     "material": {"kd": 0, "reflect": 0.5}}]})",
                     0, 0),
               grey(0.1));

  // Camera basis, looking straight down: u = (1, 0, 0), v = w x u = (0, 0, -1). A sphere at
  // z = -2 is "up" on screen, so it shows in the top row of a 1x2 image, not the bottom.
  {
    const std::string down =
        R"({"camera": {"type": "orthographic", "position": [0, 5, 0], "direction": [0, -1, 0],
                       "resolution": [1, 2], "bounds": [-1, 1, -4, 4]},
            "objects": [{"type": "sphere", "center": [0, 0, -2], "radius": 1,
                         "material": {"ka": 1, "kd": 0}}],
            "lights": [{"position": [0, 9, 0], "ambient": 1}]})";
    ok &= expect("straight down: top row", pixel(down, 0, 0), grey(1));
    ok &= expect("straight down: bottom row", pixel(down, 0, 1), grey(0));
  }

  // Looking along +z gives v = (0, -1, 0), so u and v flip: screen right is world -x.
  {
    const std::string back =
        R"({"camera": {"type": "orthographic", "position": [0, 0, -5], "direction": [0, 0, 3],
                       "resolution": [2, 1], "bounds": [-4, 4, -1, 1]},
            "objects": [{"type": "sphere", "center": [-2, 0, 0], "radius": 1,
                         "material": {"ka": 1, "kd": 0}}],
            "lights": [{"position": [0, 9, 0], "ambient": 1}]})";
    ok &= expect("looking +z: right column", pixel(back, 1, 0), grey(1));
    ok &= expect("looking +z: left column", pixel(back, 0, 0), grey(0));
  }

  // Supersample 2 on one orthographic pixel: sub-samples at x, y = +-0.5, sub-row b = 0 at the
  // top. A small sphere at (0.5, 0.5) catches only the top-right one: 1/4 of ka * Ia.
  ok &= expect("supersample: one of four",
               pixel(R"({"camera": {"type": "orthographic", "position": [0, 0, 5],
                                    "direction": [0, 0, -1], "resolution": [1, 1],
                                    "bounds": [-1, 1, -1, 1]},
                        "supersample": 2,
                        "lights": [{"position": [0, 0, 9], "ambient": 1}],
                        "objects": [{"type": "sphere", "center": [0.5, 0.5, 0], "radius": 0.3,
                                     "material": {"ka": 0.8, "kd": 0}}]})",
                     0, 0),
               grey(0.2));

  // A coloured light: each channel of kd * I * cos, times the colour. Head-on light: cos = 1.
  ok &= expect(
      "coloured light",
      pixel("{" + head_on_camera + R"(, "objects": [{"type": "sphere",
                        "center": [0, 0, 0], "radius": 1, "material": {"color": [1, 0.5, 0.25],
                        "kd": 0.6, "ka": 0.5}}],
                        "lights": [{"position": [0, 0, 10], "intensity": [0.7, 0.2, 0.1],
                                    "ambient": [0.1, 0.2, 0.4]}]})",
            1, 1),
      {1 * (0.5 * 0.1 + 0.6 * 0.7), 0.5 * (0.5 * 0.2 + 0.6 * 0.2), 0.25 * (0.5 * 0.4 + 0.6 * 0.1)});

  // Shadow through two glass spheres stacked between the ground and the light: the light is
  // passed on by 0.5 * 0.4, each sphere counted once although the segment crosses it twice.
  ok &= expect("shadow through glass",
               pixel(R"({"camera": {"type": "orthographic", "position": [0, 5, 0],
                                    "direction": [0, -1, 0], "resolution": [1, 1],
                                    "bounds": [-0.1, 0.1, -0.1, 0.1]},
                        "lights": [{"position": [0, 20, 0], "intensity": 0.8}],
                        "objects": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0],
                                     "material": {"kd": 0.5}},
                                    {"type": "sphere", "center": [0, 7, 0], "radius": 0.5,
                                     "material": {"transmit": 0.5}},
                                    {"type": "sphere", "center": [0, 12, 0], "radius": 0.5,
                                     "material": {"transmit": 0.4}}]})",
                     0, 0),
               grey(0.5 * 0.8 * 0.5 * 0.4));

  // Head-on through a glass plane: c = 1, k = 1, the ray goes straight on and misses:
  // transmit * environment. With max_depth 0 nothing is transmitted.
  {
    const std::string slab =
        R"({"camera": {"type": "orthographic", "position": [0, 0, 5], "direction": [0, 0, -1],
                       "resolution": [1, 1], "bounds": [-1, 1, -1, 1]},
            "background": 0.9, "environment": 0.2, "max_depth": 1,
            "objects": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1],
                         "material": {"kd": 0, "transmit": 0.5, "ior": 1.5}}]})";
    ok &= expect("through a glass plane", pixel(slab, 0, 0), grey(0.1));
  }

  // Total internal reflection: an orthographic camera looks down at 60 degrees from the normal
  // onto a plane of ior 0.5 (eta = 2 entering: k = 1 - 4 * 0.75 < 0), so the transmitted share
  // follows the mirror direction, up into a sphere of ka 1 above. With ior 1.5 it refracts
  // downwards and misses (environment 0).
  {
    const double s60 = std::sqrt(3.0) / 2;
    char buf[1024];
    auto scene = [&](double ior) {
      std::snprintf(buf, sizeof buf, R"({"camera": {"type": "orthographic",
          "position": [%.17g, 1, 0], "direction": [%.17g, -0.5, 0], "resolution": [1, 1],
          "bounds": [-0.01, 0.01, -0.01, 0.01]}, "max_depth": 1,
          "lights": [{"position": [0, 50, 0], "intensity": 0, "ambient": 1}],
          "objects": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0],
                       "material": {"kd": 0, "transmit": 0.5, "ior": %.17g}},
                      {"type": "sphere", "center": [%.17g, 1, 0], "radius": 0.3,
                       "material": {"ka": 1, "kd": 0}}]})",
                    -2 * s60, s60, ior, 2 * s60);
      return std::string(buf);
    };
    ok &= expect("total internal reflection", pixel(scene(0.5), 0, 0), grey(0.5));
    ok &= expect("refraction below the critical angle", pixel(scene(1.5), 0, 0), grey(0));
  }

  std::printf(ok ? "self-check passed\n" : "self-check FAILED\n");
  return ok ? 0 : 1;
}

// ---------------------------------------------------------------------------------------------
// Command line

struct Options {
  std::string scene_path, out_path;
  std::optional<int> supersample;
  std::optional<std::pair<int, int>> resolution;
  bool flux = false;
};

[[noreturn]] void usage(const std::string& problem) {
  std::fprintf(stderr,
               "lancer_oracle: %s (usage: lancer_oracle SCENE.json OUT.pfm [--supersample S] "
               "[--resolution NXxNY] [--flux])\n",
               problem.c_str());
  std::exit(2);
}

int positive_int(const std::string& text, const std::string& what) {
  size_t used = 0;
  int v = 0;
  try {
    v = std::stoi(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || v <= 0) usage("bad " + what + " '" + text + "'");
  return v;
}

Options parse_args(int argc, char** argv) {
  Options o;
  std::vector<std::string> positional;
  for (int k = 1; k < argc; ++k) {
    std::string arg = argv[k];
    if (arg == "--flux") {
      o.flux = true;
    } else if (arg == "--supersample" || arg == "--resolution") {
      if (k + 1 >= argc) usage(arg + " needs a value");
      std::string value = argv[++k];
      if (arg == "--supersample") {
        o.supersample = positive_int(value, "supersample");
      } else {
        size_t x = value.find('x');
        if (x == std::string::npos) usage("bad resolution '" + value + "'");
        o.resolution = std::make_pair(positive_int(value.substr(0, x), "resolution"),
                                      positive_int(value.substr(x + 1), "resolution"));
      }
    } else if (arg.size() > 1 && arg[0] == '-') {
      usage("unknown option " + arg);
    } else {
      positional.push_back(arg);
    }
  }
  // With --flux the output goes to stdout, so OUT.pfm may be left out (and is not written).
  size_t wanted = o.flux ? positional.size() : 2;
  if (positional.size() != wanted || wanted < 1 || wanted > 2) usage("wrong arguments");
  o.scene_path = positional[0];
  if (positional.size() == 2) o.out_path = positional[1];
  return o;
}

int run(int argc, char** argv) {
  if (argc == 2 && std::string(argv[1]) == "--self-check") return self_check();
  Options opt = parse_args(argc, argv);

  Scene scene;
  try {
    std::ifstream in(opt.scene_path);
    if (!in) {
      std::fprintf(stderr, "%s: cannot open\n", opt.scene_path.c_str());
      return 2;
    }
    scene = parse_scene(json::parse(in));
  } catch (const BadInput& e) {
    std::fprintf(stderr, "%s: %s\n", opt.scene_path.c_str(), e.what());
    return 2;
  } catch (const json::exception& e) {
    std::fprintf(stderr, "%s: %s\n", opt.scene_path.c_str(), e.what());
    return 2;
  }
  if (opt.supersample) scene.supersample = *opt.supersample;
  if (opt.resolution) {
    scene.camera.nx = opt.resolution->first;
    scene.camera.ny = opt.resolution->second;
  }

  if (opt.flux) {
    print_flux(scene);
    return 0;
  }
  std::vector<Rgb> image = render(scene, scene.camera.ny);
  if (!write_pfm(opt.out_path, image, scene.camera.nx, scene.camera.ny)) {
    std::fprintf(stderr, "%s: cannot write\n", opt.out_path.c_str());
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return run(argc, argv); }
