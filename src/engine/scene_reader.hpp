// The scene loader's reading of one JSON object at a time (ObjectReader: every key consumed,
// every value named by its path), shared by the loader's translation units
// (scene_load.cpp, scene_shapes.cpp). Internal to the engine.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "lancer/error.hpp"
#include "lancer/scene.hpp"
#include "scene_rules.hpp"

namespace lancer::load {

using json = nlohmann::json;

// Documents nested deeper than this are rejected before they can exhaust the stack.
constexpr int kMaxJsonDepth = 32;
constexpr std::size_t kMaxSceneBytes = std::size_t(1) << 30;

using rules::fail;
using rules::index_path;
using rules::kMaxRadiance;

// A key or name taken from the file, made fit for a one-line message: control characters escaped
// (a key may hold "\n"), and very long ones cut (on a UTF-8 character boundary).
inline std::string printable(const std::string& s, std::size_t max_shown = 64) {
  if (s.size() <= max_shown &&
      std::all_of(s.begin(), s.end(), [](char c) { return c >= 0x20 && c != 0x7f; }))
    return s;  // the common case, for every field read
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

inline std::string key_path(const std::string& parent, const std::string& key) {
  return parent.empty() ? printable(key) : parent + "." + printable(key);
}

// The message of the rule `check` breaks, or "" if it holds.
template <class Check>
std::string message_of(const Check& check) {
  try {
    check();
  } catch (const InputError& e) {
    return e.what();
  }
  return {};
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
    return rules::non_negative(at(key), number_or(key, fallback), max_value);
  }
  // A length: radius or distance.
  double length(const std::string& key) { return rules::length(at(key), number(key)); }
  bool boolean_or(const std::string& key, bool fallback) {
    if (!has(key)) return fallback;
    const json& v = get(key);
    if (!v.is_boolean()) fail(at(key), "must be true or false");
    return v.get<bool>();
  }
  int integer_or(const std::string& key, int fallback) {
    return has(key) ? as_integer(get(key), at(key)) : fallback;
  }
  Vec3<double> vec3(const std::string& key) { return as_vec3(get(key), at(key)); }
  // A position: every component at most kMaxCoordinate in magnitude.
  Vec3<double> point(const std::string& key) { return rules::point(at(key), vec3(key)); }
  // A direction, of any non-zero length (rescaled: rules::direction).
  Vec3<double> direction(const std::string& key) { return rules::direction(at(key), vec3(key)); }
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
      const double g = rules::non_negative(where, as_number(v, where));
      return {g, g, g};
    }
    if (!v.is_array() || v.size() != 3) fail(where, "must be a number or an array of 3 numbers");
    return rules::colour(
        where, {as_number(v[0], index_path(where, 0)), as_number(v[1], index_path(where, 1)),
                as_number(v[2], index_path(where, 2))});
  }

 private:
  const json& j_;
  std::string path_;
  std::set<std::string> seen_;
};

// "triangle", "mesh" and "cylinder": one Shape each (scene_shapes.cpp).
void read_shape(ObjectReader& o, const std::string& type, int material, Scene& s);

}  // namespace lancer::load
