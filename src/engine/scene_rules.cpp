// The scene rules shared by the file loader and the library API (scene_rules.hpp).
#include "scene_rules.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "lancer/error.hpp"

namespace lancer::rules {

void fail(const std::string& where, const std::string& what) {
  throw InputError(where + ": " + what);
}

std::string show(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

std::string index_path(const std::string& parent, std::size_t i) {
  return parent + "[" + std::to_string(i) + "]";
}

double finite(const std::string& where, double v) {
  if (!std::isfinite(v)) fail(where, "must be finite");
  return v;
}

double non_negative(const std::string& where, double v, double max_value) {
  finite(where, v);
  if (v < 0) fail(where, "must be >= 0");
  if (v > max_value) fail(where, "must be at most " + show(max_value));
  return v;
}

double length(const std::string& where, double v) {
  finite(where, v);
  if (!(v > 0)) fail(where, "must be > 0");
  if (v < kMinLength || v > kMaxCoordinate)
    fail(where, "must be from " + show(kMinLength) + " to " + show(kMaxCoordinate));
  return v;
}

namespace {
Vec3<double> finite3(const std::string& where, const Vec3<double>& v) {
  return {finite(index_path(where, 0), v.x), finite(index_path(where, 1), v.y),
          finite(index_path(where, 2), v.z)};
}
}  // namespace

Vec3<double> point(const std::string& where, const Vec3<double>& v) {
  finite3(where, v);
  const double c[3] = {v.x, v.y, v.z};
  for (int i = 0; i < 3; ++i)
    if (std::fabs(c[i]) > kMaxCoordinate)
      fail(index_path(where, i),
           "must be from " + show(-kMaxCoordinate) + " to " + show(kMaxCoordinate));
  return v;
}

Vec3<double> direction(const std::string& where, const Vec3<double>& d) {
  Vec3<double> v = finite3(where, d);
  if (v.x == 0 && v.y == 0 && v.z == 0) fail(where, "must not be zero");
  const double big = std::max({std::fabs(v.x), std::fabs(v.y), std::fabs(v.z)});
  if (big < 0x1p-64 || big > 0x1p64) {
    const int e = -std::ilogb(big);
    v = {std::ldexp(v.x, e), std::ldexp(v.y, e), std::ldexp(v.z, e)};
  }
  return v;
}

Rgb colour(const std::string& where, const Rgb& c) {
  finite(index_path(where, 0), c.r), finite(index_path(where, 1), c.g);
  finite(index_path(where, 2), c.b);
  if (c.r < 0 || c.g < 0 || c.b < 0) fail(where, "components must be >= 0");
  if (c.r > kMaxRadiance || c.g > kMaxRadiance || c.b > kMaxRadiance)
    fail(where, "components must be at most " + show(kMaxRadiance));
  return c;
}

CameraType camera_type(const std::string& where, CameraType type) {
  if (type != CameraType::pinhole && type != CameraType::orthographic)
    fail(where + ".type", "must be \"pinhole\" or \"orthographic\"");
  return type;
}

Vec3<double> camera_direction(const std::string& where, const Vec3<double>& d) {
  const Vec3<double> v = direction(where, d);
  // The contract's u = normalize((-w.z, 0, w.x)): when that vector is not zero but too short
  // to normalise in double, the camera has no usable orientation.
  const Vec3<double> w = normalize(-v);
  const double h2 = w.z * w.z + w.x * w.x;
  if ((w.x != 0 || w.z != 0) && !(h2 >= 0x1p-900))
    fail(where,
         "too close to vertical to orient the camera; make it exactly vertical or tilt it more");
  return v;
}

void resolution(const std::string& where, int nx, int ny) {
  if (nx <= 0) fail(index_path(where, 0), "must be a positive integer");
  if (ny <= 0) fail(index_path(where, 1), "must be a positive integer");
  if (nx > kMaxResolution || ny > kMaxResolution)
    fail(where, "must be at most " + std::to_string(kMaxResolution) + " per axis");
}

void bounds(const std::string& where, const double v[4]) {
  for (int i = 0; i < 4; ++i) {
    finite(index_path(where, i), v[i]);
    if (std::fabs(v[i]) > kMaxCoordinate)
      fail(index_path(where, i),
           "must be from " + show(-kMaxCoordinate) + " to " + show(kMaxCoordinate));
  }
  if (!(v[1] > v[0])) fail(where, "xmax must be > xmin");
  if (!(v[3] > v[2])) fail(where, "ymax must be > ymin");
}

double ior(const std::string& where, double v) {
  finite(where, v);
  if (!(v > 0)) fail(where, "must be > 0");
  if (v < 1 / kMaxIor || v > kMaxIor)
    fail(where, "must be from " + show(1 / kMaxIor) + " to " + show(kMaxIor));
  return v;
}

int max_depth(int v) {
  if (v < 0) fail("max_depth", "must be >= 0");
  if (v > kMaxDepth) fail("max_depth", "must be at most " + std::to_string(kMaxDepth));
  return v;
}

double epsilon(double v) {
  finite("epsilon", v);
  if (v < 0) fail("epsilon", "must be >= 0");
  return v;
}

int supersample(int v) {
  if (v < 1) fail("supersample", "must be >= 1");
  if (v > kMaxSupersample)
    fail("supersample", "must be at most " + std::to_string(kMaxSupersample));
  return v;
}

void object_count(std::size_t n) {
  if (n > kMaxObjects) fail("objects", "more than " + std::to_string(kMaxObjects) + " objects");
}

void light_count(std::size_t n) {
  if (n > kMaxLights) fail("lights", "more than " + std::to_string(kMaxLights) + " lights");
}

namespace {

// The brightest radiance a render of the scene can produce, with the model's formulas and unit
// normals (max(0, n.l) <= 1, max(0, n.h)^shininess <= 1), and the material that reaches it. A
// miss gives background (camera rays) or environment; a hit on material m at most
//   max(1, colour) * (ka * sum(ambient) + (kd + ks) * sum(intensity) * T)
//     + (reflect + transmit) * (next level),
// where the max(1, .) also bounds the shading sum before it is multiplied by the colour, the
// sums take each light's brightest channel, and T bounds the shadow rays' transmittance: the
// product over objects of max(1, transmit).
struct RadianceBound {
  double value = 0;
  int material = -1;  // -1: the background or environment
};
RadianceBound radiance_bound(const Scene& s) {
  auto max3 = [](const Rgb& c) { return std::max({c.r, c.g, c.b}); };
  double sum_intensity = 0, sum_ambient = 0;
  for (const Light& l : s.lights)
    sum_intensity += max3(l.intensity), sum_ambient += max3(l.ambient);
  std::vector<bool> used(s.materials.size(), false);
  double transmittance = 1;
  for_each_material(s, [&](int m) {
    used[m] = true;
    transmittance *= std::max(1.0, s.materials[m].transmit);
  });
  RadianceBound next;  // the level below (none below max_depth)
  for (int depth = s.max_depth; depth >= 0; --depth) {
    RadianceBound level{max3(depth == 0 ? s.background : s.environment), -1};
    for (std::size_t m = 0; m < s.materials.size(); ++m) {
      if (!used[m]) continue;
      const Material& mat = s.materials[m];
      double v = std::max(1.0, max3(mat.color)) *
                 (mat.ka * sum_ambient + (mat.kd + mat.ks) * sum_intensity * transmittance);
      // Only a material that passes rays on carries the level below: 0 x an infinite bound is
      // NaN, which would win the comparison and blame a material that reflects nothing.
      if (depth < s.max_depth && mat.reflect + mat.transmit > 0)
        v += (mat.reflect + mat.transmit) * next.value;
      if (!(v <= level.value)) level = {v, static_cast<int>(m)};
    }
    next = level;
  }
  return next;
}

}  // namespace

// The ray tree is bounded: a material that both reflects and transmits splits each ray it meets
// in two, 2^max_depth rays at worst from one camera ray, so beyond kMaxSplitDepth it is refused
// (README, "Scenes"). Without such a material the tree is a chain of at most max_depth rays.
void ray_tree(const Scene& s, const std::vector<std::string>& material_where) {
  if (s.max_depth <= kMaxSplitDepth) return;
  std::vector<bool> used(s.materials.size(), false);
  for_each_material(s, [&](int m) { used[m] = true; });
  for (std::size_t m = 0; m < s.materials.size(); ++m)
    if (used[m] && s.materials[m].reflect > 0 && s.materials[m].transmit > 0)
      fail(material_where[m],
           "reflects and transmits, so the ray tree doubles per bounce: "
           "max_depth must be at most " +
               std::to_string(kMaxSplitDepth) + " with it, not " + std::to_string(s.max_depth));
}

void radiance(const Scene& s, const std::vector<std::string>& material_where) {
  const RadianceBound b = radiance_bound(s);
  if (b.value <= kMaxRadiance) return;
  char what[160];
  std::snprintf(what, sizeof what,
                "with these lights%s, radiance could reach %s%g; at most %g renders in single "
                "precision",
                s.max_depth > 0 ? " and reflections" : "", std::isinf(b.value) ? "beyond " : "",
                std::isinf(b.value) ? std::numeric_limits<double>::max() : b.value, kMaxRadiance);
  fail(b.material >= 0 ? material_where[b.material] : std::string("background"), what);
}

void sample_count(const Scene& s) {
  const auto& c = s.camera;
  if (static_cast<long long>(c.nx) * c.ny * s.supersample * s.supersample > kMaxSamples)
    fail("camera.resolution",
         "resolution x supersample^2 exceeds " + std::to_string(kMaxSamples) + " samples");
}

namespace {

void check_camera(CameraSpec& c) {
  const std::string cam = "camera";
  camera_type(cam, c.type);
  point(cam + ".position", c.position);
  c.direction = camera_direction(cam + ".direction", c.direction);
  if (c.type == CameraType::pinhole) length(cam + ".distance", c.distance);
  resolution(cam + ".resolution", c.nx, c.ny);
  const double b[4] = {c.xmin, c.xmax, c.ymin, c.ymax};
  bounds(cam + ".bounds", b);
}

void check_material(const Material& m, const std::string& where) {
  colour(where + ".color", m.color);
  for (const MaterialCoefficient& k : kMaterialCoefficients)
    non_negative(where + "." + k.key, m.*k.member, k.max_value);
  ior(where + ".ior", m.ior);
}

int material_of(const Scene& s, int m, std::size_t object) {
  if (m < 0 || std::size_t(m) >= s.materials.size())
    fail(index_path("objects", object) + ".material", "no material " + std::to_string(m) + " (" +
                                                          std::to_string(s.materials.size()) +
                                                          " described)");
  return m;
}

// Every part in the loader's order: camera, the top level's values, materials, lights, objects,
// then the rules over the whole scene.
void check_parts(Scene& s) {
  check_camera(s.camera);
  colour("background", s.background);
  colour("environment", s.environment);
  max_depth(s.max_depth);
  epsilon(s.epsilon);
  supersample(s.supersample);
  std::vector<std::string> material_where(s.materials.size());
  for (std::size_t m = 0; m < s.materials.size(); ++m) {
    material_where[m] = index_path("materials", m);
    check_material(s.materials[m], material_where[m]);
  }
  light_count(s.lights.size());
  for (std::size_t k = 0; k < s.lights.size(); ++k) {
    const std::string where = index_path("lights", k);
    point(where + ".position", s.lights[k].position);
    colour(where + ".intensity", s.lights[k].intensity);
    colour(where + ".ambient", s.lights[k].ambient);
  }
  object_count(s.spheres.size() + s.planes.size());
  std::size_t k = 0;
  for (Sphere& sp : s.spheres) {
    const std::string where = index_path("objects", k);
    material_of(s, sp.material, k++);
    point(where + ".center", sp.center);
    length(where + ".radius", sp.radius);
  }
  for (Plane& p : s.planes) {
    const std::string where = index_path("objects", k);
    material_of(s, p.material, k++);
    point(where + ".point", p.point);
    p.normal = direction(where + ".normal", p.normal);
  }
  ray_tree(s, material_where);
  radiance(s, material_where);
  sample_count(s);
}

}  // namespace

void check_description(Scene& s) {
  const std::string name = s.name.empty() ? "scene" : s.name;
  try {
    check_parts(s);
  } catch (const InputError& e) {
    throw InputError(name + ": " + e.what());
  }
}

}  // namespace lancer::rules
