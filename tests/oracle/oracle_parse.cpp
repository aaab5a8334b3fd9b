// lancer_oracle's scene loader: the JSON document to the model of oracle_model.hpp.
#include <initializer_list>
#include <string>

#include "oracle_model.hpp"

namespace oracle {
namespace {

using nlohmann::json;

// ---------------------------------------------------------------------------------------------
// Parsing. Validation is minimal but every rejection names its place, like the engine's.

[[noreturn]] void bad(const std::string& where, const std::string& what) {
  throw BadInput(where + ": " + what);
}

std::string at(const std::string& where, const std::string& key) {
  return where.empty() ? key : where + "." + key;
}
std::string at(const std::string& where, size_t index) {
  return where + "[" + std::to_string(index) + "]";
}

void only_keys(const json& j, const std::string& where, std::initializer_list<const char*> keys) {
  if (!j.is_object()) bad(where.empty() ? "scene" : where, "must be an object");
  for (const auto& item : j.items()) {
    bool known =
        std::any_of(keys.begin(), keys.end(), [&](const char* k) { return item.key() == k; });
    if (!known) bad(at(where, item.key()), "unknown key");
  }
}

const json* field(const json& obj, const char* key) {
  auto it = obj.find(key);
  return it == obj.end() ? nullptr : &*it;
}

const json& required(const json& obj, const std::string& where, const char* key) {
  const json* j = field(obj, key);
  if (!j) bad(at(where, key), "missing");
  return *j;
}

double number(const json& j, const std::string& where) {
  if (!j.is_number()) bad(where, "must be a number");
  double v = j.get<double>();
  if (!std::isfinite(v)) bad(where, "must be finite");
  return v;
}

double non_negative(const json& j, const std::string& where) {
  double v = number(j, where);
  if (v < 0) bad(where, "must be >= 0");
  return v;
}

long long integer(const json& j, const std::string& where) {
  if (!j.is_number_integer()) bad(where, "must be an integer");
  return j.get<long long>();
}

Vec vec3(const json& j, const std::string& where) {
  if (!j.is_array() || j.size() != 3) bad(where, "must be [x, y, z]");
  return {number(j[0], at(where, 0)), number(j[1], at(where, 1)), number(j[2], at(where, 2))};
}

Rgb color(const json& j, const std::string& where) {
  if (j.is_number()) {
    double grey = number(j, where);
    return {grey, grey, grey};
  }
  if (!j.is_array() || j.size() != 3) bad(where, "must be a number or [r, g, b]");
  return {number(j[0], at(where, 0)), number(j[1], at(where, 1)), number(j[2], at(where, 2))};
}

Material parse_material(const json& j, const std::string& where) {
  only_keys(j, where, {"color", "ka", "kd", "ks", "shininess", "reflect", "transmit", "ior"});
  Material m;
  if (const json* c = field(j, "color")) m.color = color(*c, at(where, "color"));
  auto coefficient = [&](const char* key, double& out) {
    if (const json* c = field(j, key)) out = non_negative(*c, at(where, key));
  };
  coefficient("ka", m.ka);
  coefficient("kd", m.kd);
  coefficient("ks", m.ks);
  coefficient("shininess", m.shininess);
  coefficient("reflect", m.reflect);
  coefficient("transmit", m.transmit);
  if (const json* i = field(j, "ior")) {
    m.ior = number(*i, at(where, "ior"));
    if (m.ior <= 0) bad(at(where, "ior"), "must be > 0");
  }
  return m;
}

using MaterialTable = std::map<std::string, Material>;

// An object's material is a name from "materials", an inline object, or absent (all defaults).
Material object_material(const json& obj, const std::string& where, const MaterialTable& named) {
  const json* m = field(obj, "material");
  if (!m) return Material{};
  if (m->is_string()) {
    auto it = named.find(m->get<std::string>());
    if (it == named.end())
      bad(at(where, "material"), "undefined material '" + m->get<std::string>() + "'");
    return it->second;
  }
  return parse_material(*m, at(where, "material"));
}

Object parse_object(const json& j, const std::string& where, const MaterialTable& named) {
  if (!j.is_object()) bad(where, "must be an object");
  const json& type = required(j, where, "type");
  Object o;
  if (type == "sphere") {
    only_keys(j, where, {"type", "center", "radius", "material"});
    o.shape = Shape::kSphere;
    o.center = vec3(required(j, where, "center"), at(where, "center"));
    o.radius = number(required(j, where, "radius"), at(where, "radius"));
    if (o.radius <= 0) bad(at(where, "radius"), "must be > 0");
  } else if (type == "plane") {
    only_keys(j, where, {"type", "point", "normal", "material"});
    o.shape = Shape::kPlane;
    o.center = vec3(required(j, where, "point"), at(where, "point"));
    Vec n = vec3(required(j, where, "normal"), at(where, "normal"));
    if (is_zero(n)) bad(at(where, "normal"), "must not be zero");
    o.normal = normalize(n);
  } else if (type == "triangle") {
    only_keys(j, where, {"type", "vertices", "material"});
    o.shape = Shape::kTriangle;
    const json& vs = required(j, where, "vertices");
    if (!vs.is_array() || vs.size() != 3) bad(at(where, "vertices"), "must be 3 points");
    for (int k = 0; k < 3; ++k) o.v[k] = vec3(vs[std::size_t(k)], at(where, "vertices"));
    o.normal = cross(o.v[1] - o.v[0], o.v[2] - o.v[0]);
    if (is_zero(o.normal)) bad(at(where, "vertices"), "on one line");
    o.normal = normalize(o.normal);
  } else if (type == "cylinder") {
    only_keys(j, where, {"type", "base", "top", "radius", "caps", "material"});
    o.shape = Shape::kCylinder;
    o.v[0] = vec3(required(j, where, "base"), at(where, "base"));
    o.v[1] = vec3(required(j, where, "top"), at(where, "top"));
    o.radius = number(required(j, where, "radius"), at(where, "radius"));
    if (o.radius <= 0) bad(at(where, "radius"), "must be > 0");
    if (is_zero(o.v[1] - o.v[0])) bad(at(where, "top"), "must differ from base");
    if (const json* c = field(j, "caps")) {
      if (!c->is_boolean()) bad(at(where, "caps"), "must be true or false");
      o.caps = c->get<bool>();
    }
  } else {
    bad(at(where, "type"), "must be \"sphere\", \"plane\", \"triangle\" or \"cylinder\"");
  }
  o.material = object_material(j, where, named);
  return o;
}

Light parse_light(const json& j, const std::string& where) {
  only_keys(j, where, {"position", "intensity", "ambient"});
  Light l;
  l.position = vec3(required(j, where, "position"), at(where, "position"));
  auto non_negative_color = [&](const char* key, Rgb& out) {
    if (const json* c = field(j, key)) {
      out = color(*c, at(where, key));
      if (out.r < 0 || out.g < 0 || out.b < 0) bad(at(where, key), "must be >= 0");
    }
  };
  non_negative_color("intensity", l.intensity);
  non_negative_color("ambient", l.ambient);
  return l;
}

Camera parse_camera(const json& j, const std::string& where) {
  only_keys(j, where, {"type", "position", "direction", "distance", "resolution", "bounds"});
  Camera c;
  const json& type = required(j, where, "type");
  if (type != "pinhole" && type != "orthographic") {
    bad(at(where, "type"), "must be \"pinhole\" or \"orthographic\"");
  }
  c.pinhole = type == "pinhole";
  c.position = vec3(required(j, where, "position"), at(where, "position"));
  c.direction = vec3(required(j, where, "direction"), at(where, "direction"));
  if (is_zero(c.direction)) bad(at(where, "direction"), "must not be zero");
  if (c.pinhole) {
    c.distance = number(required(j, where, "distance"), at(where, "distance"));
    if (c.distance <= 0) bad(at(where, "distance"), "must be > 0");
  }
  const json& res = required(j, where, "resolution");
  if (!res.is_array() || res.size() != 2) bad(at(where, "resolution"), "must be [nx, ny]");
  long long nx = integer(res[0], at(at(where, "resolution"), 0));
  long long ny = integer(res[1], at(at(where, "resolution"), 1));
  if (nx <= 0 || ny <= 0 || nx > 1 << 16 || ny > 1 << 16) {
    bad(at(where, "resolution"), "must be positive (and at most 65536)");
  }
  c.nx = static_cast<int>(nx);
  c.ny = static_cast<int>(ny);
  const json& b = required(j, where, "bounds");
  if (!b.is_array() || b.size() != 4) bad(at(where, "bounds"), "must be [xmin, xmax, ymin, ymax]");
  c.xmin = number(b[0], at(at(where, "bounds"), 0));
  c.xmax = number(b[1], at(at(where, "bounds"), 1));
  c.ymin = number(b[2], at(at(where, "bounds"), 2));
  c.ymax = number(b[3], at(at(where, "bounds"), 3));
  if (!(c.xmin < c.xmax) || !(c.ymin < c.ymax)) bad(at(where, "bounds"), "empty or inverted");
  return c;
}

}  // namespace

Scene parse_scene(const json& j) {
  only_keys(j, "",
            {"camera", "background", "environment", "max_depth", "epsilon", "supersample",
             "materials", "lights", "objects"});
  Scene s;
  s.camera = parse_camera(required(j, "", "camera"), "camera");
  if (const json* b = field(j, "background")) s.background = color(*b, "background");
  s.environment = s.background;
  if (const json* e = field(j, "environment")) s.environment = color(*e, "environment");
  if (const json* d = field(j, "max_depth")) {
    long long depth = integer(*d, "max_depth");
    if (depth < 0 || depth > 1000) bad("max_depth", "must be in 0..1000");
    s.max_depth = static_cast<int>(depth);
  }
  if (const json* e = field(j, "epsilon")) s.epsilon = number(*e, "epsilon");
  if (const json* ss = field(j, "supersample")) {
    long long n = integer(*ss, "supersample");
    if (n < 1 || n > 64) bad("supersample", "must be in 1..64");
    s.supersample = static_cast<int>(n);
  }
  MaterialTable named;
  if (const json* ms = field(j, "materials")) {
    if (!ms->is_object()) bad("materials", "must be an object");
    for (const auto& item : ms->items()) {
      named[item.key()] = parse_material(item.value(), at("materials", item.key()));
    }
  }
  // Lights and objects may be absent: an empty scene is still a scene.
  if (const json* ls = field(j, "lights")) {
    if (!ls->is_array()) bad("lights", "must be an array");
    for (size_t i = 0; i < ls->size(); ++i)
      s.lights.push_back(parse_light((*ls)[i], at("lights", i)));
  }
  if (const json* os = field(j, "objects")) {
    if (!os->is_array()) bad("objects", "must be an array");
    for (size_t i = 0; i < os->size(); ++i) {
      s.objects.push_back(parse_object((*os)[i], at("objects", i), named));
    }
  }
  return s;
}

}  // namespace oracle
