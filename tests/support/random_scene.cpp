#include "support/random_scene.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <string>

namespace lancer::testing {
namespace {

using nlohmann::json;
using Vec = std::array<double, 3>;

// Draws from mt19937_64 with our own mappings: the std distributions are implementation-defined,
// and a seed must give the same scene with every standard library.
class Rng {
 public:
  explicit Rng(uint64_t seed) : gen_(seed) {}
  double uniform() { return static_cast<double>(gen_() >> 11) * 0x1.0p-53; }  // [0, 1)
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  double log_uniform(double lo, double hi) { return lo * std::exp(std::log(hi / lo) * uniform()); }
  int integer(int lo, int hi) {  // [lo, hi]; the modulo bias is irrelevant here
    return lo + static_cast<int>(gen_() % static_cast<uint64_t>(hi - lo + 1));
  }
  bool chance(double p) { return uniform() < p; }

 private:
  std::mt19937_64 gen_;
};

constexpr double kPi = 3.14159265358979323846;

Vec scaled(const Vec& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
json to_json(const Vec& a) { return json::array({a[0], a[1], a[2]}); }

Vec random_direction(Rng& rng) {  // uniform on the unit sphere
  double z = rng.uniform(-1, 1);
  double phi = rng.uniform(0, 2 * kPi);
  double r = std::sqrt(1 - z * z);
  return {r * std::cos(phi), r * std::sin(phi), z};
}

json random_color(Rng& rng) {
  if (rng.chance(0.3)) return rng.uniform();  // grey, written as one number
  return json::array({rng.uniform(), rng.uniform(), rng.uniform()});
}

// Every field is sometimes left out so that the contract's defaults get exercised.
json random_material(Rng& rng, const RandomSceneOptions& opt) {
  json m = json::object();
  if (rng.chance(0.8)) m["color"] = random_color(rng);
  if (rng.chance(0.8)) m["ka"] = rng.uniform();
  if (rng.chance(0.8)) m["kd"] = rng.uniform();
  if (rng.chance(0.5)) {
    m["ks"] = 1 - rng.uniform();  // (0, 1]
  } else if (rng.chance(0.5)) {
    m["ks"] = 0;
  }
  if (rng.chance(0.8)) {
    m["shininess"] = rng.chance(0.5) ? json(rng.integer(1, 200)) : json(rng.uniform(1, 200));
  }
  if (rng.chance(0.5)) {
    m["reflect"] = 1 - rng.uniform();  // (0, 1]
  } else if (rng.chance(0.5)) {
    m["reflect"] = 0;
  }
  if (opt.glass && rng.chance(0.35)) {
    m["transmit"] = rng.uniform(0.1, 1);
    if (rng.chance(0.85))
      m["ior"] = rng.chance(0.25) ? rng.uniform(0.5, 0.95) : rng.uniform(1.05, 2.5);
  }
  return m;
}

json random_sphere(Rng& rng, const RandomSceneOptions& opt) {
  double distance = rng.log_uniform(opt.min_distance, opt.max_distance);
  return {{"type", "sphere"},
          {"center", to_json(scaled(random_direction(rng), distance))},
          {"radius", rng.log_uniform(opt.min_radius, opt.max_radius)}};
}

json random_plane(Rng& rng, const RandomSceneOptions& opt) {
  double distance = rng.log_uniform(opt.min_distance, opt.max_distance);
  Vec normal = random_direction(rng);
  if (rng.chance(0.4)) {  // axis-aligned planes are the common case in real scenes
    normal = {0, 0, 0};
    int axis = rng.integer(0, 2);
    normal[axis] = rng.chance(0.5) ? 1 : -1;
  }
  // Not unit length on purpose: the contract normalises plane normals.
  return {{"type", "plane"},
          {"point", to_json(scaled(random_direction(rng), distance))},
          {"normal", to_json(scaled(normal, rng.uniform(0.5, 3)))}};
}

json random_light(Rng& rng, const RandomSceneOptions& opt) {
  // One draw per statement: the order of evaluation of function arguments is unspecified.
  Vec direction = random_direction(rng);
  json light = {{"position", to_json(scaled(direction, rng.log_uniform(1, 100)))}};
  if (rng.chance(0.8)) light["intensity"] = rng.uniform(0, 1.5);
  if (rng.chance(0.5)) light["ambient"] = rng.uniform(0, 0.5);
  if (opt.glass && rng.chance(0.4)) {
    const double r = rng.uniform(0, 1.5), g = rng.uniform(0, 1.5), b = rng.uniform(0, 1.5);
    light["intensity"] = json::array({r, g, b});
  }
  if (opt.glass && rng.chance(0.3)) {
    const double r = rng.uniform(0, 0.5), g = rng.uniform(0, 0.5), b = rng.uniform(0, 0.5);
    light["ambient"] = json::array({r, g, b});
  }
  return light;
}

json random_camera(Rng& rng, const RandomSceneOptions& opt) {
  double d = rng.uniform(5, 60);
  Vec position, direction;
  if (rng.chance(0.1)) {  // exactly straight down: the camera basis's special case
    position = {rng.uniform(-0.1, 0.1) * d, d, rng.uniform(-0.1, 0.1) * d};
    direction = {0, -1, 0};
  } else {  // towards the origin, jittered; |jitter| < d keeps it non-zero
    position = scaled(random_direction(rng), d);
    Vec jitter = random_direction(rng);
    jitter = scaled(jitter, rng.uniform(0, 0.2) * d);
    direction = {jitter[0] - position[0], jitter[1] - position[1], jitter[2] - position[2]};
  }
  json camera = {{"position", to_json(position)},
                 {"direction", to_json(direction)},
                 {"resolution", {opt.nx, opt.ny}}};
  double half_width;
  if (rng.chance(0.5)) {
    double distance = rng.uniform(0.5, 5);
    half_width = distance * std::tan(rng.uniform(0.2, 0.7));  // half-angle of 11..40 degrees
    camera["type"] = "pinhole";
    camera["distance"] = distance;
  } else {
    half_width = d * rng.uniform(0.1, 0.6);
    camera["type"] = "orthographic";
  }
  // Roughly square pixels, a little off centre.
  double aspect = static_cast<double>(opt.ny) / opt.nx;
  double half_height = half_width * aspect * rng.uniform(0.8, 1.25);
  double cx = rng.uniform(-0.2, 0.2) * half_width;
  double cy = rng.uniform(-0.2, 0.2) * half_height;
  camera["bounds"] = {cx - half_width, cx + half_width, cy - half_height, cy + half_height};
  return camera;
}

}  // namespace

json random_scene(uint64_t seed, const RandomSceneOptions& opt) {
  Rng rng(seed);
  json scene = {{"camera", random_camera(rng, opt)}};
  if (rng.chance(0.7)) scene["background"] = random_color(rng);
  if (rng.chance(0.6)) scene["environment"] = random_color(rng);
  int depth = rng.integer(0, opt.max_depth);
  if (depth > 0 || rng.chance(0.5)) scene["max_depth"] = depth;
  int supersample = rng.integer(1, 2);
  if (supersample > 1 || rng.chance(0.5)) scene["supersample"] = supersample;

  int named = rng.integer(0, 3);
  for (int k = 0; k < named; ++k) {
    scene["materials"]["mat" + std::to_string(k)] = random_material(rng, opt);
  }

  scene["lights"] = json::array();
  int lights = rng.integer(0, 4);
  for (int k = 0; k < lights; ++k) scene["lights"].push_back(random_light(rng, opt));

  // Log-uniform count: small scenes (easy to debug) are common, max_objects still occurs.
  int count = static_cast<int>(rng.log_uniform(1, opt.max_objects + 1));
  count = std::max(1, std::min(count, opt.max_objects));
  // An infinite plane often fills the whole view, so only some scenes get one or two.
  int planes = opt.planes && rng.chance(0.4) ? std::min(rng.integer(1, 2), count) : 0;
  scene["objects"] = json::array();
  for (int k = 0; k < count; ++k) {
    bool plane = rng.uniform() * (count - k) < planes;  // planes land at random places in the list
    json object = plane ? random_plane(rng, opt) : random_sphere(rng, opt);
    planes -= plane;
    if (named > 0 && rng.chance(0.3)) {
      object["material"] = "mat" + std::to_string(rng.integer(0, named - 1));
    } else if (rng.chance(0.9)) {
      object["material"] = random_material(rng, opt);
    }  // else: no material, all defaults
    scene["objects"].push_back(object);
  }
  return scene;
}

}  // namespace lancer::testing
