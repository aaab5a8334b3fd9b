// Scene files: JSON in exactly the format of SCENE-MODEL.md, validated strictly. Every error is
// one line naming the place, as `objects[2].radius: must be > 0`.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <vector>

#include "lancer/error.hpp"
#include "lancer/scene.hpp"

namespace lancer {
namespace {

using json = nlohmann::json;

// Documents nested deeper than this are rejected before they can exhaust the stack.
constexpr int kMaxJsonDepth = 32;
constexpr std::size_t kMaxSceneBytes = std::size_t(1) << 30;

// Ranges beyond the contract's own rules, so that a render in single precision stays finite
// (issue 7; each was a fuzzing finding, kept in tests/fuzz/test_regressions.cpp):
// - coordinates (positions, centres, points, bounds) and lengths (radius, distance) at most
//   kMaxCoordinate in magnitude: squared distances between them stay below FLT_MAX;
// - radius and distance at least kMinLength: their squares stay normal floats, not 0;
// - brightness (colours, coefficients, intensities, background) at most kMaxRadiance, and so the
//   brightest radiance the scene can produce (scene_radiance_bound), times 64^2 sub-samples
//   summed, stays below FLT_MAX;
// - shininess at most kMaxShininess: a cosine one float step above 1 raised to it stays near 1.
constexpr double kMaxCoordinate = 1e18;
constexpr double kMinLength = 1e-18;
constexpr double kMaxRadiance = 1e34;
constexpr double kMaxShininess = 1e6;
// - ior from 1/kMaxIor to kMaxIor: eta^2 in the refracted direction stays a normal float.
constexpr double kMaxIor = 1e6;

[[noreturn]] void fail(const std::string& where, const std::string& what) {
  throw InputError(where + ": " + what);
}

// A key or name taken from the file, made fit for a one-line message: control characters escaped
// (a key may hold "\n"), and very long ones cut (on a UTF-8 character boundary).
std::string printable(const std::string& s, std::size_t max_shown = 64) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const unsigned char ch = static_cast<unsigned char>(s[i]);
    if (i >= max_shown && (ch & 0xC0) != 0x80) {
      out += "...";
      break;
    }
    if (ch == '\n') {
      out += "\\n";
    } else if (ch == '\r') {
      out += "\\r";
    } else if (ch == '\t') {
      out += "\\t";
    } else if (ch < 0x20 || ch == 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", ch);
      out += buf;
    } else {
      out += static_cast<char>(ch);
    }
  }
  return out;
}

std::string key_path(const std::string& parent, const std::string& key) {
  return parent.empty() ? printable(key) : parent + "." + printable(key);
}

std::string index_path(const std::string& parent, std::size_t i) {
  return parent + "[" + std::to_string(i) + "]";
}

// One JSON object being read: remembers which keys were consumed so that any other key is an
// error, and names every value by its path.
class ObjectReader {
 public:
  ObjectReader(const json& j, std::string path) : j_(j), path_(std::move(path)) {
    if (!j_.is_object()) fail(where(), "must be an object");
  }

  bool has(const std::string& key) const { return j_.contains(key); }
  const std::string& where() const {
    static const std::string top = "(top level)";
    return path_.empty() ? top : path_;
  }
  std::string at(const std::string& key) const { return key_path(path_, key); }

  const json& get(const std::string& key) {
    seen_.insert(key);
    auto it = j_.find(key);
    if (it == j_.end()) fail(at(key), "missing required field");
    return *it;
  }

  double number(const std::string& key) { return as_number(get(key), at(key)); }
  double number_or(const std::string& key, double fallback) {
    return has(key) ? number(key) : fallback;
  }
  double non_negative_or(const std::string& key, double fallback, double max_value = kMaxRadiance) {
    double v = number_or(key, fallback);
    if (v < 0) fail(at(key), "must be >= 0");
    if (v > max_value) fail(at(key), "must be at most " + show(max_value));
    return v;
  }
  // A length: radius or distance.
  double length(const std::string& key) {
    const double v = number(key);
    if (!(v > 0)) fail(at(key), "must be > 0");
    if (v < kMinLength || v > kMaxCoordinate)
      fail(at(key), "must be from " + show(kMinLength) + " to " + show(kMaxCoordinate));
    return v;
  }
  int integer_or(const std::string& key, int fallback) {
    return has(key) ? as_integer(get(key), at(key)) : fallback;
  }
  Vec3<double> vec3(const std::string& key) { return as_vec3(get(key), at(key)); }
  // A position: every component at most kMaxCoordinate in magnitude.
  Vec3<double> point(const std::string& key) {
    const Vec3<double> v = vec3(key);
    const double c[3] = {v.x, v.y, v.z};
    for (int i = 0; i < 3; ++i)
      if (std::fabs(c[i]) > kMaxCoordinate)
        fail(index_path(at(key), i),
             "must be from " + show(-kMaxCoordinate) + " to " + show(kMaxCoordinate));
    return v;
  }
  // A direction, of any non-zero length. One far from 1 is scaled by a power of two, which
  // changes no bit of its normalised value but keeps |v|^2 from underflowing or overflowing.
  Vec3<double> direction(const std::string& key) {
    Vec3<double> v = vec3(key);
    if (v.x == 0 && v.y == 0 && v.z == 0) fail(at(key), "must not be zero");
    const double big = std::max({std::fabs(v.x), std::fabs(v.y), std::fabs(v.z)});
    if (big < 0x1p-64 || big > 0x1p64) {
      const int e = -std::ilogb(big);
      v = {std::ldexp(v.x, e), std::ldexp(v.y, e), std::ldexp(v.z, e)};
    }
    return v;
  }
  Rgb rgb_or(const std::string& key, Rgb fallback) {
    return has(key) ? as_rgb(get(key), at(key)) : fallback;
  }
  std::string string(const std::string& key) {
    const json& v = get(key);
    if (!v.is_string()) fail(at(key), "must be a string");
    return v.get<std::string>();
  }

  // Called last: any key that no reader asked for is unknown.
  void finish() const {
    for (auto it = j_.begin(); it != j_.end(); ++it)
      if (!seen_.count(it.key())) fail(at(it.key()), "unknown key");
  }

  static std::string show(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    return buf;
  }

  static double as_number(const json& v, const std::string& where) {
    if (!v.is_number()) fail(where, "must be a number");
    double d = v.get<double>();
    if (!std::isfinite(d)) fail(where, "must be finite");
    return d;
  }
  static int as_integer(const json& v, const std::string& where) {
    double d = as_number(v, where);
    if (d != std::floor(d) || std::fabs(d) > 2147483647.0) fail(where, "must be an integer");
    return static_cast<int>(d);
  }
  static Vec3<double> as_vec3(const json& v, const std::string& where) {
    if (!v.is_array() || v.size() != 3) fail(where, "must be an array of 3 numbers");
    return {as_number(v[0], index_path(where, 0)), as_number(v[1], index_path(where, 1)),
            as_number(v[2], index_path(where, 2))};
  }
  static Rgb as_rgb(const json& v, const std::string& where) {
    if (v.is_number()) {
      double g = as_number(v, where);
      if (g < 0) fail(where, "must be >= 0");
      if (g > kMaxRadiance) fail(where, "must be at most " + show(kMaxRadiance));
      return {g, g, g};
    }
    if (!v.is_array() || v.size() != 3) fail(where, "must be a number or an array of 3 numbers");
    Rgb c{as_number(v[0], index_path(where, 0)), as_number(v[1], index_path(where, 1)),
          as_number(v[2], index_path(where, 2))};
    if (c.r < 0 || c.g < 0 || c.b < 0) fail(where, "components must be >= 0");
    if (c.r > kMaxRadiance || c.g > kMaxRadiance || c.b > kMaxRadiance)
      fail(where, "components must be at most " + show(kMaxRadiance));
    return c;
  }

 private:
  const json& j_;
  std::string path_;
  std::set<std::string> seen_;
};

CameraSpec read_camera(const json& j) {
  ObjectReader r(j, "camera");
  CameraSpec c;
  std::string type = r.string("type");
  if (type == "pinhole")
    c.type = CameraType::pinhole;
  else if (type == "orthographic")
    c.type = CameraType::orthographic;
  else
    fail(r.at("type"), "must be \"pinhole\" or \"orthographic\"");
  c.position = r.point("position");
  c.direction = r.direction("direction");
  {
    // The contract's u = normalize((-w.z, 0, w.x)): when that vector is not zero but too short
    // to normalise in double, the camera has no usable orientation.
    const Vec3<double> w = normalize(-c.direction);
    const double h2 = w.z * w.z + w.x * w.x;
    if ((w.x != 0 || w.z != 0) && !(h2 >= 0x1p-900))
      fail(r.at("direction"),
           "too close to vertical to orient the camera; make it exactly vertical or tilt it more");
  }
  if (c.type == CameraType::pinhole) {
    c.distance = r.length("distance");
  } else if (r.has("distance")) {
    r.number("distance");  // accepted and unused: an orthographic camera has no eye distance
  }
  const json& res = r.get("resolution");
  if (!res.is_array() || res.size() != 2) fail(r.at("resolution"), "must be [nx, ny]");
  c.nx = ObjectReader::as_integer(res[0], index_path(r.at("resolution"), 0));
  c.ny = ObjectReader::as_integer(res[1], index_path(r.at("resolution"), 1));
  if (c.nx <= 0) fail(index_path(r.at("resolution"), 0), "must be a positive integer");
  if (c.ny <= 0) fail(index_path(r.at("resolution"), 1), "must be a positive integer");
  if (c.nx > kMaxResolution || c.ny > kMaxResolution)
    fail(r.at("resolution"), "must be at most " + std::to_string(kMaxResolution) + " per axis");
  const json& b = r.get("bounds");
  if (!b.is_array() || b.size() != 4) fail(r.at("bounds"), "must be [xmin, xmax, ymin, ymax]");
  double v[4];
  for (int i = 0; i < 4; ++i) {
    v[i] = ObjectReader::as_number(b[i], index_path(r.at("bounds"), i));
    if (std::fabs(v[i]) > kMaxCoordinate)
      fail(index_path(r.at("bounds"), i), "must be from " + ObjectReader::show(-kMaxCoordinate) +
                                              " to " + ObjectReader::show(kMaxCoordinate));
  }
  c.xmin = v[0], c.xmax = v[1], c.ymin = v[2], c.ymax = v[3];
  if (!(c.xmax > c.xmin)) fail(r.at("bounds"), "xmax must be > xmin");
  if (!(c.ymax > c.ymin)) fail(r.at("bounds"), "ymax must be > ymin");
  r.finish();
  return c;
}

Material read_material(const json& j, const std::string& path) {
  ObjectReader r(j, path);
  Material m;
  m.color = r.rgb_or("color", m.color);
  m.ka = r.non_negative_or("ka", m.ka);
  m.kd = r.non_negative_or("kd", m.kd);
  m.ks = r.non_negative_or("ks", m.ks);
  m.shininess = r.non_negative_or("shininess", m.shininess, kMaxShininess);
  m.reflect = r.non_negative_or("reflect", m.reflect);
  m.transmit = r.non_negative_or("transmit", m.transmit);
  m.ior = r.number_or("ior", m.ior);
  if (!(m.ior > 0)) fail(r.at("ior"), "must be > 0");
  if (m.ior < 1 / kMaxIor || m.ior > kMaxIor)
    fail(r.at("ior"),
         "must be from " + ObjectReader::show(1 / kMaxIor) + " to " + ObjectReader::show(kMaxIor));
  r.finish();
  return m;
}

Light read_light(const json& j, const std::string& path) {
  ObjectReader r(j, path);
  Light l;
  l.position = r.point("position");
  l.intensity = r.rgb_or("intensity", l.intensity);
  l.ambient = r.rgb_or("ambient", l.ambient);
  r.finish();
  return l;
}

// A syntax error's byte offset turned into the line number people look for.
std::size_t line_of(const std::string& text, std::size_t byte) {
  std::size_t line = 1;
  for (std::size_t i = 0; i < byte && i < text.size(); ++i) line += text[i] == '\n';
  return line;
}

// nlohmann's own DOM builder, refusing documents nested deeper than kMaxJsonDepth as it reads them
// (its parser is iterative, so this bounds memory, not the stack). Not json::parse with a
// callback: that DOM builder rescans the enclosing array for discarded values after every
// object, quadratic in the length of an array of objects (a million spheres took minutes).
class DepthLimitedDom {
 public:
  using number_integer_t = json::number_integer_t;
  using number_unsigned_t = json::number_unsigned_t;
  using number_float_t = json::number_float_t;
  using string_t = json::string_t;
  using binary_t = json::binary_t;

  DepthLimitedDom(json& result, const std::string& name) : dom_(result, true), name_(name) {}

  bool null() { return dom_.null(); }
  bool boolean(bool v) { return dom_.boolean(v); }
  bool number_integer(number_integer_t v) { return dom_.number_integer(v); }
  bool number_unsigned(number_unsigned_t v) { return dom_.number_unsigned(v); }
  bool number_float(number_float_t v, const string_t& text) { return dom_.number_float(v, text); }
  bool string(string_t& v) { return dom_.string(v); }
  bool binary(binary_t& v) { return dom_.binary(v); }
  bool key(string_t& v) { return dom_.key(v); }
  bool start_object(std::size_t n) {
    enter();
    return dom_.start_object(n);
  }
  bool end_object() {
    --depth_;
    return dom_.end_object();
  }
  bool start_array(std::size_t n) {
    enter();
    return dom_.start_array(n);
  }
  bool end_array() {
    --depth_;
    return dom_.end_array();
  }
  template <class Exception>
  bool parse_error(std::size_t position, const std::string& token, const Exception& e) {
    return dom_.parse_error(position, token, e);  // throws e
  }

 private:
  void enter() {
    if (depth_ >= kMaxJsonDepth)
      fail(name_, "nested deeper than " + std::to_string(kMaxJsonDepth) + " levels");
    ++depth_;
  }

  nlohmann::detail::json_sax_dom_parser<json> dom_;
  const std::string& name_;
  int depth_ = 0;
};

json parse_json(const std::string& text, const std::string& name) {
  if (text.size() > kMaxSceneBytes) fail(name, "file larger than 1 GiB");
  try {
    json doc;
    DepthLimitedDom dom(doc, name);
    json::sax_parse(text, &dom, json::input_format_t::json, /*strict=*/true,
                    /*ignore_comments=*/false);
    return doc;
  } catch (const json::parse_error& e) {
    // e.what() reads "[json.exception.parse_error.101] parse error at line 3, column 5: ..."
    std::string what = e.what();
    auto colon = what.find(": ");
    std::string detail = colon == std::string::npos ? what : what.substr(colon + 2);
    fail(name + ":" + std::to_string(line_of(text, e.byte == 0 ? 0 : e.byte - 1)),
         "syntax error: " + printable(detail, 200));
  } catch (const json::out_of_range& e) {
    // A literal such as 1e999: the parser reports no position, so quote the number instead.
    std::string what = e.what();
    auto bracket = what.find("] ");
    fail(name, printable(bracket == std::string::npos ? what : what.substr(bracket + 2), 80) +
                   " (numbers must be finite)");
  }
}

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
  for (const Sphere& sp : s.spheres) used[sp.material] = true;
  for (const Plane& p : s.planes) used[p.material] = true;
  double transmittance = 1;
  for (const Sphere& sp : s.spheres)
    transmittance *= std::max(1.0, s.materials[sp.material].transmit);
  for (const Plane& p : s.planes) transmittance *= std::max(1.0, s.materials[p.material].transmit);
  RadianceBound next;  // the level below (none below max_depth)
  for (int depth = s.max_depth; depth >= 0; --depth) {
    RadianceBound level{max3(depth == 0 ? s.background : s.environment), -1};
    for (std::size_t m = 0; m < s.materials.size(); ++m) {
      if (!used[m]) continue;
      const Material& mat = s.materials[m];
      double v = std::max(1.0, max3(mat.color)) *
                 (mat.ka * sum_ambient + (mat.kd + mat.ks) * sum_intensity * transmittance);
      if (depth < s.max_depth) v += (mat.reflect + mat.transmit) * next.value;
      if (!(v <= level.value)) level = {v, static_cast<int>(m)};
    }
    next = level;
  }
  return next;
}

// The ray tree is bounded: a material that both reflects and transmits splits each ray it meets
// in two, 2^max_depth rays at worst from one camera ray, so beyond kMaxSplitDepth it is refused
// (README, "Scenes"). Without such a material the tree is a chain of at most max_depth rays.
void check_ray_tree(const Scene& s, const std::vector<std::string>& material_where) {
  if (s.max_depth <= kMaxSplitDepth) return;
  std::vector<bool> used(s.materials.size(), false);
  for (const Sphere& sp : s.spheres) used[sp.material] = true;
  for (const Plane& p : s.planes) used[p.material] = true;
  for (std::size_t m = 0; m < s.materials.size(); ++m)
    if (used[m] && s.materials[m].reflect > 0 && s.materials[m].transmit > 0)
      fail(material_where[m],
           "reflects and transmits, so the ray tree doubles per bounce: "
           "max_depth must be at most " +
               std::to_string(kMaxSplitDepth) + " with it, not " + std::to_string(s.max_depth));
}

void check_radiance(const Scene& s, const std::vector<std::string>& material_where) {
  const RadianceBound b = radiance_bound(s);
  if (b.value <= kMaxRadiance) return;
  char what[160];
  std::snprintf(what, sizeof what,
                "with these lights%s, radiance could reach %g; at most %g renders in single "
                "precision",
                s.max_depth > 0 ? " and reflections" : "", b.value, kMaxRadiance);
  fail(b.material >= 0 ? material_where[b.material] : std::string("background"), what);
}

}  // namespace

Scene parse_scene(const std::string& text, const std::string& name) {
  json doc = parse_json(text, name);
  Scene s;
  s.name = name;
  try {
    ObjectReader top(doc, "");
    s.camera = read_camera(top.get("camera"));
    s.background = top.rgb_or("background", Rgb{});
    s.environment = top.rgb_or("environment", s.background);
    s.max_depth = top.integer_or("max_depth", 0);
    if (s.max_depth < 0) fail("max_depth", "must be >= 0");
    if (s.max_depth > kMaxDepth) fail("max_depth", "must be at most " + std::to_string(kMaxDepth));
    s.epsilon = top.number_or("epsilon", 1e-4);
    if (s.epsilon < 0) fail("epsilon", "must be >= 0");
    s.supersample = top.integer_or("supersample", 1);
    if (s.supersample < 1) fail("supersample", "must be >= 1");
    if (s.supersample > kMaxSupersample)
      fail("supersample", "must be at most " + std::to_string(kMaxSupersample));

    std::map<std::string, int> named;
    std::vector<std::string> material_where;  // the place each material is defined, for messages
    if (top.has("materials")) {
      const json& mats = top.get("materials");
      if (!mats.is_object()) fail("materials", "must be an object of named materials");
      for (auto it = mats.begin(); it != mats.end(); ++it) {
        named[it.key()] = static_cast<int>(s.materials.size());
        s.materials.push_back(read_material(it.value(), key_path("materials", it.key())));
        material_where.push_back(key_path("materials", it.key()));
      }
    }

    if (top.has("lights")) {
      const json& lights = top.get("lights");
      if (!lights.is_array()) fail("lights", "must be an array");
      for (std::size_t i = 0; i < lights.size(); ++i)
        s.lights.push_back(read_light(lights[i], index_path("lights", i)));
    }

    const json& objects = top.get("objects");
    if (!objects.is_array()) fail("objects", "must be an array");
    int default_material = -1;
    for (std::size_t i = 0; i < objects.size(); ++i) {
      const std::string path = index_path("objects", i);
      ObjectReader o(objects[i], path);
      int material;
      if (o.has("material")) {
        const json& m = o.get("material");
        if (m.is_string()) {
          auto it = named.find(m.get<std::string>());
          if (it == named.end())
            fail(o.at("material"),
                 "material \"" + printable(m.get<std::string>()) + "\" is not defined");
          material = it->second;
        } else if (m.is_object()) {
          material = static_cast<int>(s.materials.size());
          s.materials.push_back(read_material(m, o.at("material")));
          material_where.push_back(o.at("material"));
        } else {
          fail(o.at("material"), "must be a material name or a material object");
        }
      } else {
        if (default_material < 0) {
          default_material = static_cast<int>(s.materials.size());
          s.materials.push_back(Material{});
          material_where.push_back(path + " (default material)");
        }
        material = default_material;
      }
      const std::string type = o.string("type");
      if (type == "sphere") {
        Sphere sp;
        sp.center = o.point("center");
        sp.radius = o.length("radius");
        sp.material = material;
        s.spheres.push_back(sp);
      } else if (type == "plane") {
        Plane p;
        p.point = o.point("point");
        p.normal = o.direction("normal");
        p.material = material;
        s.planes.push_back(p);
      } else {
        fail(o.at("type"), "must be \"sphere\" or \"plane\"");
      }
      o.finish();
    }
    top.finish();
    check_ray_tree(s, material_where);
    check_radiance(s, material_where);
  } catch (const InputError& e) {
    throw InputError(name + ": " + e.what());
  } catch (const json::exception& e) {
    // Should not happen: every access above checks the type first. Still one line, no trace.
    fail(name, std::string("invalid scene: ") + e.what());
  }
  const auto& c = s.camera;
  if (static_cast<long long>(c.nx) * c.ny * s.supersample * s.supersample > kMaxSamples)
    fail(name + ": camera.resolution",
         "resolution x supersample^2 exceeds " + std::to_string(kMaxSamples) + " samples");
  return s;
}

Scene load_scene(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError(path + ": is a folder, not a scene file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open scene file");
  // Read at most 1 GiB + 1 byte, so that /dev/zero or a runaway pipe fails instead of filling
  // memory; reserve once when the size is known (a regular file).
  std::string text;
  const auto size = std::filesystem::file_size(path, ec);
  if (!ec && size > kMaxSceneBytes) throw InputError(path + ": file larger than 1 GiB");
  if (!ec) text.reserve(static_cast<std::size_t>(size));
  std::vector<char> buf(std::size_t(1) << 16);
  while (in.read(buf.data(), static_cast<std::streamsize>(buf.size())) || in.gcount() > 0) {
    text.append(buf.data(), static_cast<std::size_t>(in.gcount()));
    if (text.size() > kMaxSceneBytes) throw InputError(path + ": file larger than 1 GiB");
  }
  if (in.bad()) throw InputError(path + ": cannot read scene file");
  return parse_scene(text, path);
}

}  // namespace lancer
