// Scene files: JSON in exactly the format of SCENE-MODEL.md, validated strictly. Every error is
// one line naming the place, as `objects[2].radius: must be > 0`.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <vector>

#include "lancer/error.hpp"
#include "lancer/input_file.hpp"
#include "lancer/mesh_io.hpp"
#include "lancer/scene.hpp"
#include "lancer/text.hpp"
#include "scene_reader.hpp"
#include "scene_rules.hpp"

namespace lancer {
namespace {

using namespace load;  // ObjectReader (scene_reader.hpp)

CameraSpec read_camera(const json& j) {
  ObjectReader r(j, "camera");
  CameraSpec c;
  // docs/scene-format.md: "pinhole" when not given.
  const std::string type = r.has("type") ? r.string("type") : "pinhole";
  c.type = rules::camera_type("camera", type == "pinhole"        ? CameraType::pinhole
                                        : type == "orthographic" ? CameraType::orthographic
                                                                 : CameraType(-1));
  c.position = r.point("position");
  c.direction = rules::camera_direction(r.at("direction"), r.vec3("direction"));
  if (c.type == CameraType::pinhole) {
    c.distance = r.length("distance");
  } else if (r.has("distance")) {
    r.number("distance");  // accepted and unused: an orthographic camera has no eye distance
  }
  const json& res = r.get("resolution");
  if (!res.is_array() || res.size() != 2) fail(r.at("resolution"), "must be [nx, ny]");
  c.nx = ObjectReader::as_integer(res[0], index_path(r.at("resolution"), 0));
  c.ny = ObjectReader::as_integer(res[1], index_path(r.at("resolution"), 1));
  rules::resolution(r.at("resolution"), c.nx, c.ny);
  const json& b = r.get("bounds");
  if (!b.is_array() || b.size() != 4) fail(r.at("bounds"), "must be [xmin, xmax, ymin, ymax]");
  double v[4];
  for (int i = 0; i < 4; ++i) v[i] = ObjectReader::as_number(b[i], index_path(r.at("bounds"), i));
  rules::bounds(r.at("bounds"), v);
  c.xmin = v[0], c.xmax = v[1], c.ymin = v[2], c.ymax = v[3];
  r.finish();
  return c;
}

Material read_material(const json& j, const std::string& path) {
  ObjectReader r(j, path);
  Material m;
  m.color = r.rgb_or("color", m.color);
  for (const rules::MaterialCoefficient& k : rules::kMaterialCoefficients)
    m.*k.member = r.non_negative_or(k.key, m.*k.member, k.max_value);
  m.ior = rules::ior(r.at("ior"), r.number_or("ior", m.ior));
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

// Builds the small DOM of one value (one object, one light, one material, the camera) from the
// streaming parser's events, so that the document as a whole is never held: memory stays near the
// size of the scene's own data. Refuses duplicate keys (nlohmann keeps the last silently), and
// keeps at most kMaxArrayKept elements of an array and kMaxKeysKept keys of an object: no value
// of the format is longer, so what is dropped is already an error ("must be an array of 3
// numbers"), and `[0,0,0,...]` cannot make lancer allocate in proportion to it.
class ValueBuilder {
 public:
  static constexpr std::size_t kMaxArrayKept = 8;
  static constexpr std::size_t kMaxKeysKept = 32;

  // keep = false: parse the value and store nothing (a value already known to be an error).
  // The place is given as a function, called only for a message: no string per value.
  template <class Place>
  void begin(const Place& place, bool keep) {
    place_ = place;
    root_ = json();
    stack_.clear();
    slot_ = nullptr;
    depth_ = 0;
    discard_at_ = keep ? -1 : 0;
    error_.clear();
    active_ = true;
  }
  bool active() const { return active_; }
  // Each returns true when the value begun last is complete.
  bool scalar(json v) {
    if (discard_at_ < 0)
      if (json* slot = slot_for_value()) *slot = std::move(v);
    return done_if(depth_ == 0);
  }
  void open(json::value_t kind) {
    if (discard_at_ < 0) {
      if (json* slot = slot_for_value()) {
        *slot = json(kind);
        stack_.push_back(slot);
      } else {
        discard_at_ = depth_;
      }
    }
    ++depth_;
  }
  bool close() {
    --depth_;
    if (discard_at_ >= 0) {
      if (depth_ == discard_at_ && depth_ > 0) discard_at_ = -1;
    } else {
      stack_.pop_back();
    }
    return done_if(depth_ == 0);
  }
  // A key of the innermost object. A duplicate stops the building; error() says where.
  void key(std::string& k) {
    if (discard_at_ >= 0) return;
    auto& object = stack_.back()->get_ref<json::object_t&>();
    const bool full = object.size() >= kMaxKeysKept;
    if (!full) {
      auto [it, added] = object.try_emplace(std::move(k), nullptr);  // k kept if present
      if (added) {
        slot_ = &it->second;
        return;
      }
    }
    error_ = where() + ": " +
             (full ? "more than " + std::to_string(kMaxKeysKept) + " keys"
                   : "duplicate key \"" + printable(k) + "\"");
    discard_at_ = 0;
  }
  const std::string& error() const { return error_; }
  json& value() { return root_; }

 private:
  bool done_if(bool done) {
    if (done) active_ = false;
    return done;
  }
  json* slot_for_value() {
    if (stack_.empty()) return &root_;
    json& parent = *stack_.back();
    if (parent.is_array()) {
      if (parent.size() >= kMaxArrayKept) return nullptr;
      parent.push_back(nullptr);
      return &parent.back();
    }
    return slot_;  // made by key()
  }
  // The innermost object's place, for messages: `objects[3].material`. Found by looking each
  // open container up in its parent, so that building keeps no path.
  std::string where() const {
    std::string w = place_();
    for (std::size_t i = 1; i < stack_.size(); ++i) {
      const json& parent = *stack_[i - 1];
      if (parent.is_array()) {
        for (std::size_t k = 0; k < parent.size(); ++k)
          if (&parent[k] == stack_[i]) w = index_path(w, k);
      } else {
        for (auto it = parent.begin(); it != parent.end(); ++it)
          if (&it.value() == stack_[i]) w = key_path(w, it.key());
      }
    }
    return w.empty() ? "(top level)" : w;
  }

  std::function<std::string()> place_;
  json root_;
  std::vector<json*> stack_;
  json* slot_ = nullptr;  // the object member the next value goes to
  int depth_ = 0;
  int discard_at_ = -1;  // >= 0: storing nothing until the depth is back to this
  std::string error_;
  bool active_ = false;
};

// Materials by name, resolved when the file is done: a file may define them after the objects
// that use them, and the scene's materials are the named ones in name order, then the inline
// (and default) ones in the order of their objects, as they always were.
class MaterialTable {
 public:
  // A reference from an object: a code that finish() turns into an index.
  // Once the file's "materials" are all read, an unknown name fails at once, at its object.
  int reference(const std::string& name, std::size_t object, const std::string& where) {
    auto it = ids_.find(name);  // one look-up: this runs for every object
    if (it != ids_.end() && defined_[it->second]) return -1 - it->second;
    if (closed_) fail(where, "material \"" + printable(name) + "\" is not defined");
    const int id = it != ids_.end() ? it->second : id_of(name);
    if (first_use_[id] < 0) first_use_[id] = static_cast<long long>(object);
    return -1 - id;
  }
  // Every object without a material shares one default, made when the first such object comes.
  int default_material(const std::string& object_path) {
    if (default_ < 0) default_ = add_inline(Material{}, object_path + " (default material)");
    return default_;
  }
  int add_inline(const Material& m, std::string where) {
    inline_.push_back(m);
    inline_where_.push_back(std::move(where));
    return static_cast<int>(inline_.size() - 1);
  }
  bool defined(const std::string& name) const {
    auto it = ids_.find(name);
    return it != ids_.end() && defined_[it->second];
  }
  void define(const std::string& name, const Material& m) {
    const int id = id_of(name);
    defined_[id] = true;
    named_[id] = m;
  }
  void close() { closed_ = true; }
  std::size_t named_count() const { return ids_.size(); }
  std::size_t inline_count() const { return inline_.size(); }

  // The first object (in file order) that names a material nobody defined, if any.
  struct Undefined {
    long long object = -1;
    std::string name;
  };
  Undefined first_undefined() const {
    Undefined u;
    for (const auto& [name, id] : ids_)
      if (!defined_[id] && first_use_[id] >= 0 && (u.object < 0 || first_use_[id] < u.object))
        u = {first_use_[id], name};
    return u;
  }

  // Moves the materials into the scene and turns every object's code into an index.
  void finish(Scene& s, std::vector<std::string>& where) {
    std::vector<int> index(ids_.size(), -1);
    int next = 0;
    for (const auto& [name, id] : ids_) {  // std::map: name order
      if (!defined_[id]) continue;
      index[id] = next++;
      s.materials.push_back(named_[id]);
      where.push_back(key_path("materials", name));
    }
    for (std::size_t k = 0; k < inline_.size(); ++k) {
      s.materials.push_back(inline_[k]);
      where.push_back(std::move(inline_where_[k]));
    }
    auto resolve = [&](int& code) { code = code < 0 ? index[-1 - code] : next + code; };
    for (Sphere& sp : s.spheres) resolve(sp.material);
    for (Plane& p : s.planes) resolve(p.material);
    for (Shape& sh : s.shapes)
      resolve(sh.kind == Shape::Kind::mesh ? sh.mesh.material : sh.cylinder.material);
  }

 private:
  int id_of(const std::string& name) {
    auto [it, added] = ids_.emplace(name, static_cast<int>(ids_.size()));
    if (added) {
      defined_.push_back(false);
      named_.emplace_back();
      first_use_.push_back(-1);
    }
    return it->second;
  }
  std::map<std::string, int> ids_;
  std::vector<bool> defined_;
  std::vector<Material> named_;
  std::vector<long long> first_use_;
  std::vector<Material> inline_;
  std::vector<std::string> inline_where_;
  int default_ = -1;
  bool closed_ = false;
};

// Every object's material, in object-id order.

// One element of "objects", converted at once and dropped.
void read_object(const json& j, std::size_t index, MaterialTable& materials, Scene& s,
                 std::vector<bool>* is_plane) {
  const std::string path = index_path("objects", index);
  ObjectReader o(j, path);
  int material;
  if (o.has("material")) {
    const json& m = o.get("material");
    if (m.is_string()) {
      material = materials.reference(m.get<std::string>(), index, o.at("material"));
    } else if (m.is_object()) {
      material = materials.add_inline(read_material(m, o.at("material")), o.at("material"));
    } else {
      fail(o.at("material"), "must be a material name or a material object");
    }
  } else {
    material = materials.default_material(path);
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
  } else if (type == "triangle" || type == "mesh" || type == "cylinder") {
    read_shape(o, type, material, s);
  } else {
    fail(o.at("type"), "must be \"sphere\", \"plane\", \"triangle\", \"mesh\" or \"cylinder\"");
  }
  o.finish();
  if (is_plane) is_plane->push_back(type == "plane");
}

// The first error of one part of the file. Errors are kept, not thrown, while the file is read,
// so that a syntax error anywhere still wins and the parts are reported in the order the loader
// always checked them (camera first, objects last), whatever order the file has.
struct FirstError {
  std::string message;  // "" while none
  std::string order;    // among several, the smallest wins (a material's name)
  bool set() const { return !message.empty(); }
  void keep(std::string what, std::string rank = {}) {
    if (set() && !(rank < order)) return;
    message = std::move(what);
    order = std::move(rank);
  }
};

// The streaming parse of a whole scene (nlohmann's SAX interface): the top level's small values
// (camera, background, ...) are kept as small DOMs and read at the end; every element of
// "objects", "lights" and "materials" is built alone, converted and dropped.
class SceneSax {
 public:
  using number_integer_t = json::number_integer_t;
  using number_unsigned_t = json::number_unsigned_t;
  using number_float_t = json::number_float_t;
  using string_t = json::string_t;
  using binary_t = json::binary_t;

  SceneSax(Scene& s, const std::string& name, std::vector<bool>* is_plane)
      : s_(s), name_(name), is_plane_(is_plane) {}

  bool null() { return scalar(json(nullptr)); }
  bool boolean(bool v) { return scalar(json(v)); }
  bool number_integer(number_integer_t v) { return scalar(json(v)); }
  bool number_unsigned(number_unsigned_t v) { return scalar(json(v)); }
  bool number_float(number_float_t v, const string_t&) { return scalar(json(v)); }
  bool string(string_t& v) { return scalar(json(std::move(v))); }
  bool binary(binary_t&) { return scalar(json(nullptr)); }  // not produced by JSON text
  bool start_object(std::size_t) { return open(json::value_t::object); }
  bool start_array(std::size_t) { return open(json::value_t::array); }
  bool end_object() { return close(); }
  bool end_array() { return close(); }
  bool key(string_t& k) {
    if (value_.active()) {
      value_.key(k);
      if (!value_.error().empty()) structure(value_.error());
    } else if (place_ == Place::materials) {
      if (seen_material_names_.count(k))
        structure("materials: duplicate key \"" + printable(k) + "\"");
      else if (seen_material_names_.size() >= kMaxNamedMaterials)
        structure("materials: more than " + std::to_string(kMaxNamedMaterials) + " materials");
      else
        seen_material_names_.insert(k);
      key_ = std::move(k);
    } else {  // the top level
      if (is_top_key(k) && !top_keys_.insert(k).second)
        structure("(top level): duplicate key \"" + printable(k) + "\"");
      key_ = std::move(k);
    }
    return true;
  }
  template <class Exception>
  bool parse_error(std::size_t, const std::string&, const Exception& e) {
    throw e;
  }

  // After a complete parse: the scene, or the first error in the loader's order of checks.
  void finish() {
    if (structure_.set()) throw InputError(structure_.message);
    ObjectReader top(top_, "");
    s_.camera = read_camera(top.get("camera"));
    s_.background = top.rgb_or("background", Rgb{});
    s_.environment = top.rgb_or("environment", s_.background);
    s_.max_depth = rules::max_depth(top.integer_or("max_depth", 0));
    s_.epsilon = rules::epsilon(top.number_or("epsilon", 1e-4));
    s_.supersample = rules::supersample(top.integer_or("supersample", 1));
    for (const FirstError* e : {&materials_error_, &lights_error_})
      if (e->set()) throw InputError(e->message);
    if (!top_keys_.count("objects")) fail("objects", "missing required field");
    const MaterialTable::Undefined u = materials_.first_undefined();
    if (u.object >= 0 && (objects_error_at_ < 0 || u.object <= objects_error_at_))
      fail(index_path("objects", static_cast<std::size_t>(u.object)) + ".material",
           "material \"" + printable(u.name) + "\" is not defined");
    if (objects_error_.set()) throw InputError(objects_error_.message);
    if (unknown_.set()) throw InputError(unknown_.message);
    std::vector<std::string> material_where;
    materials_.finish(s_, material_where);
    rules::ray_tree(s_, material_where);
    rules::radiance(s_, material_where);
  }

 private:
  enum class Place { top_value, top, objects, lights, materials, done };
  static constexpr const char* kSmallKeys[] = {"camera",    "background", "environment",
                                               "max_depth", "epsilon",    "supersample"};

  void enter() {
    if (depth_ >= kMaxJsonDepth)
      fail(name_, "nested deeper than " + std::to_string(kMaxJsonDepth) + " levels");
    ++depth_;
  }
  // A structural error (duplicate key, top level not an object, too many elements): it wins over
  // every other, and nothing after it is kept.
  void structure(const std::string& message) {
    if (!structure_.set()) structure_.message = message;
  }
  bool skipping_all() const { return structure_.set(); }

  bool scalar(json v) {
    if (!value_.active()) begin_value(json::value_t::null);
    if (value_.scalar(std::move(v))) end_value();
    return true;
  }
  bool open(json::value_t kind) {
    enter();
    if (!value_.active() && !begin_value(kind)) return true;
    value_.open(kind);
    return true;
  }
  bool close() {
    --depth_;
    if (value_.active()) {
      if (value_.close()) end_value();
    } else if (place_ == Place::top) {
      place_ = Place::done;
    } else {  // the end of "objects", "lights" or "materials"
      if (place_ == Place::materials) materials_.close();
      place_ = Place::top;
    }
    return true;
  }

  // A value starts where none is being built: walk it here (the top level, "objects", "lights",
  // "materials"; returns false) or begin building it (true).
  bool begin_value(json::value_t kind) {
    const bool is_object = kind == json::value_t::object;
    const bool is_array = kind == json::value_t::array;
    kept_ = false;
    switch (place_) {
      case Place::top_value:
        if (is_object) {
          place_ = Place::top;
          return false;
        }
        structure("(top level): must be an object");
        break;
      case Place::top:
        if (skipping_all()) break;
        if (key_ == "objects") {
          if (is_array) return place_ = Place::objects, false;
          objects_error_.keep("objects: must be an array");
        } else if (key_ == "lights") {
          if (is_array) return place_ = Place::lights, false;
          lights_error_.keep("lights: must be an array");
        } else if (key_ == "materials") {
          if (is_object) return place_ = Place::materials, false;
          materials_error_.keep("materials: must be an object of named materials");
        } else if (is_small_key(key_)) {
          kept_ = true;
        } else {
          unknown_.keep(printable(key_) + ": unknown key", key_);
        }
        break;
      case Place::objects:
        index_ = objects_++;
        if (objects_ > kMaxObjects) structure(message_of([&] { rules::object_count(objects_); }));
        kept_ = !skipping_all() && !objects_error_.set() && !lights_error_.set() &&
                !materials_error_.set();
        if (kept_) value_.begin([i = index_] { return index_path("objects", i); }, true);
        break;
      case Place::lights:
        index_ = lights_++;
        if (lights_ > kMaxLights) structure(message_of([&] { rules::light_count(lights_); }));
        kept_ = !skipping_all() && !lights_error_.set() && !materials_error_.set();
        if (kept_) value_.begin([i = index_] { return index_path("lights", i); }, true);
        break;
      case Place::materials:
        kept_ = !skipping_all();
        if (kept_) value_.begin([k = key_] { return key_path("materials", k); }, true);
        break;
      case Place::done:
        break;
    }
    if (place_ == Place::top && kept_) value_.begin([k = key_] { return k; }, true);
    if (!kept_) value_.begin([] { return std::string(); }, false);
    return true;
  }

  // A value built (or skipped) is complete: convert it now.
  void end_value() {
    if (!value_.error().empty() || !kept_ || skipping_all()) {
      if (place_ == Place::top_value) place_ = Place::done;
      return;
    }
    json& v = value_.value();
    try {
      switch (place_) {
        case Place::top:
          top_[key_] = std::move(v);
          break;
        case Place::objects:
          try {
            read_object(v, index_, materials_, s_, is_plane_);
          } catch (const InputError&) {
            objects_error_at_ = static_cast<long long>(index_);
            throw;
          }
          break;
        case Place::lights:
          s_.lights.push_back(read_light(v, index_path("lights", index_)));
          break;
        case Place::materials:
          materials_.define(key_, read_material(v, key_path("materials", key_)));
          break;
        default:
          break;
      }
    } catch (const InputError& e) {
      FirstError& part = place_ == Place::objects  ? objects_error_
                         : place_ == Place::lights ? lights_error_
                                                   : materials_error_;
      part.keep(e.what(), place_ == Place::materials ? key_ : std::string());
    }
  }

  static bool is_top_key(const std::string& k) {
    return is_small_key(k) || k == "objects" || k == "lights" || k == "materials";
  }
  static bool is_small_key(const std::string& k) {
    for (const char* small : kSmallKeys)
      if (k == small) return true;
    return false;
  }

  Scene& s_;
  const std::string& name_;
  std::vector<bool>* is_plane_;
  Place place_ = Place::top_value;
  int depth_ = 0;
  bool kept_ = false;      // the value being built is converted when complete
  std::size_t index_ = 0;  // its index in "objects" or "lights"
  std::string key_;
  ValueBuilder value_;
  json top_ = json::object();  // the small values of the top level
  std::set<std::string> top_keys_;
  std::set<std::string> seen_material_names_;
  MaterialTable materials_;
  std::size_t objects_ = 0, lights_ = 0;
  FirstError structure_, materials_error_, lights_error_, objects_error_, unknown_;
  long long objects_error_at_ = -1;
};

}  // namespace

namespace {
// parse_scene, messages naming the file `name` (as shown), mesh files found beside `path`.
Scene parse_scene_at(const std::string& text, const std::string& name, const std::string& path,
                     std::vector<bool>* is_plane) {
  if (text.size() > kMaxSceneBytes) fail(name, "file larger than 1 GiB");
  // nlohmann's lexer takes a NUL for the end of the input and would ignore what follows.
  if (const std::size_t nul = text.find('\0'); nul != std::string::npos)
    fail(name + ":" + std::to_string(line_of(text, nul)),
         "syntax error: NUL byte at offset " + std::to_string(nul) + " (a scene is JSON text)");
  Scene s;
  s.name = path;
  if (is_plane) is_plane->clear();
  try {
    SceneSax sax(s, name, is_plane);
    try {
      json::sax_parse(text, &sax, json::input_format_t::json, /*strict=*/true,
                      /*ignore_comments=*/false);
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
    try {
      sax.finish();
    } catch (const InputError& e) {
      throw InputError(name + ": " + e.what());
    } catch (const json::exception& e) {
      // Should not happen: every access checks the type first. Still one line, no trace.
      fail(name, std::string("invalid scene: ") + e.what());
    }
  } catch (const std::bad_alloc&) {
    fail(name, "out of memory while loading the scene (" + std::to_string(text.size()) +
                   " bytes, " + std::to_string(s.num_objects()) + " objects read)");
  }
  if (const std::string e = message_of([&] { rules::sample_count(s); }); !e.empty()) fail(name, e);
  return s;
}

}  // namespace

Scene parse_scene(const std::string& text, const std::string& name, std::vector<bool>* is_plane) {
  return parse_scene_at(text, name, name, is_plane);
}

Scene parse_scene(const std::string& text, const std::string& name) {
  return parse_scene_at(text, name, name, nullptr);
}

std::string read_scene_file(const std::string& path) {
  return read_input_file(path, kMaxSceneBytes, "scene file", "1 GiB");
}

std::string read_input_file(const std::string& path, const std::string& what) {
  return read_input_file(path, kMaxSceneBytes, what.c_str(), "1 GiB");
}

// Messages name the file as shown_path() shows it: one line whatever the name holds.
Scene load_scene(const std::string& path) {
  return parse_scene_at(read_scene_file(path), shown_path(path), path, nullptr);
}

}  // namespace lancer
