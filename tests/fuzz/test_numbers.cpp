// Extreme numbers: random scenes with intensities from 1e-30 to 1e30, shininess 0 and 1e4, radii
// from 1e-6 to 1e6 and coordinates up to 1e6 must render without a NaN or an infinity in any
// pixel, at width 1 and at every packet width this CPU runs, in every precision.
//
// Each iteration has its own seed, printed on failure (SCOPED_TRACE) with the scene itself;
// LANCER_NUMBERS_SEED=<seed> reruns one, LANCER_NUMBERS_ITERATIONS=<n> runs more (default 5000;
// 300 in Debug and ASan builds),
// LANCER_NUMBERS_DUMP=<folder> writes each failing scene there as extreme-<seed>.json.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <ostream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "lancer/packet/api.hpp"
#include "lancer/render.hpp"
#include "lancer/scene.hpp"

namespace lancer {

// Test names and messages show "exact", "double", "fast".
inline void PrintTo(Precision p, std::ostream* os) { *os << to_string(p); }

namespace {

using nlohmann::json;

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : gen_(seed) {}
  double uniform() { return static_cast<double>(gen_() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  double log_uniform(double lo, double hi) { return lo * std::exp(std::log(hi / lo) * uniform()); }
  int integer(int lo, int hi) { return lo + static_cast<int>(gen_() % std::uint64_t(hi - lo + 1)); }
  bool chance(double p) { return uniform() < p; }
  double sign() { return chance(0.5) ? 1.0 : -1.0; }

 private:
  std::mt19937_64 gen_;
};

// A coordinate: 0, or up to 1e6 in magnitude on a log scale.
double coordinate(Rng& r) { return r.chance(0.1) ? 0.0 : r.sign() * r.log_uniform(1e-3, 1e6); }

json vec(double x, double y, double z) { return json::array({x, y, z}); }

json extreme_material(Rng& r) {
  json m = json::object();
  m["color"] = r.chance(0.3) ? json(r.uniform())
                             : vec(r.chance(0.2) ? 0.0 : r.uniform(), r.uniform(), r.uniform());
  m["ka"] = r.chance(0.3) ? 0.0 : r.uniform();
  m["kd"] = r.uniform();
  m["ks"] = r.chance(0.3) ? 0.0 : r.uniform(0, 1);
  const int kind = r.integer(0, 4);
  m["shininess"] = kind == 0   ? 0.0
                   : kind == 1 ? 1e4
                   : kind == 2 ? 1.0
                   : kind == 3 ? r.uniform(0, 200)
                               : std::floor(r.uniform(2, 300));
  m["reflect"] = r.chance(0.4) ? 0.0 : r.uniform(0, 0.95);
  return m;
}

// Spheres of radius 1e-6 .. 1e6 anywhere within 1e6, a camera aimed at one of them from up to
// 1e6 away, lights of intensity 1e-30 .. 1e30.
json extreme_scene(std::uint64_t seed) {
  Rng r(seed);
  json objects = json::array();
  const int spheres = r.integer(1, 6);
  std::vector<std::array<double, 4>> placed;
  for (int i = 0; i < spheres; ++i) {
    const double radius = r.log_uniform(1e-6, 1e6);
    const double cx = coordinate(r), cy = coordinate(r), cz = coordinate(r);
    placed.push_back({cx, cy, cz, radius});
    objects.push_back({{"type", "sphere"},
                       {"center", vec(cx, cy, cz)},
                       {"radius", radius},
                       {"material", extreme_material(r)}});
  }
  const int planes = r.integer(0, 2);
  for (int i = 0; i < planes; ++i) {
    json normal = vec(r.uniform(-1, 1), r.uniform(-1, 1), r.uniform(-1, 1));
    if (r.chance(0.3)) normal = vec(0, 1, 0);
    if (normal[0] == 0.0 && normal[1] == 0.0 && normal[2] == 0.0) normal = vec(0, 0, 1);
    objects.push_back({{"type", "plane"},
                       {"point", vec(coordinate(r), coordinate(r), coordinate(r))},
                       {"normal", normal},
                       {"material", extreme_material(r)}});
  }
  json lights = json::array();
  const int nlights = r.integer(0, 4);
  for (int i = 0; i < nlights; ++i) {
    json l = {{"position", vec(coordinate(r), coordinate(r), coordinate(r))},
              {"intensity", r.log_uniform(1e-30, 1e30)}};
    if (r.chance(0.5)) l["ambient"] = r.log_uniform(1e-30, 1e30);
    lights.push_back(l);
  }
  // Aim at a sphere, from a distance of its radius times 1.5 .. 1e3, capped at 1e6 in coordinates.
  const auto& target = placed[r.integer(0, spheres - 1)];
  double dx = r.uniform(-1, 1), dy = r.uniform(-1, 1), dz = r.uniform(-1, 1);
  const double len = std::sqrt(dx * dx + dy * dy + dz * dz) + 1e-9;
  const double away = std::min(target[3] * r.log_uniform(1.5, 1e3), 1e6);
  const double px = std::clamp(target[0] + dx / len * away, -1e6, 1e6);
  const double py = std::clamp(target[1] + dy / len * away, -1e6, 1e6);
  const double pz = std::clamp(target[2] + dz / len * away, -1e6, 1e6);
  json dir = vec(target[0] - px, target[1] - py, target[2] - pz);
  if (dir[0] == 0.0 && dir[1] == 0.0 && dir[2] == 0.0) dir = vec(0, 0, -1);
  json camera;
  const double half = target[3] * r.log_uniform(0.5, 3);  // the sphere fills part of the view
  if (r.chance(0.7)) {
    const double distance =
        std::sqrt((target[0] - px) * (target[0] - px) + (target[1] - py) * (target[1] - py) +
                  (target[2] - pz) * (target[2] - pz)) +
        1e-6;
    camera = {{"type", "pinhole"}, {"distance", std::max(distance, 1e-3)}};
  } else {
    camera = {{"type", "orthographic"}};
  }
  camera["position"] = vec(px, py, pz);
  camera["direction"] = dir;
  camera["resolution"] = json::array({13, 7});
  camera["bounds"] = json::array({-half, half, -half * 0.6, half * 0.6});
  json scene = {{"camera", camera}, {"lights", lights}, {"objects", objects}};
  scene["max_depth"] = r.integer(0, 5);
  scene["background"] = r.chance(0.5) ? json(r.uniform()) : json(r.log_uniform(1e-30, 1e30));
  if (r.chance(0.5)) scene["environment"] = r.uniform();
  const int eps = r.integer(0, 3);
  if (eps == 1) scene["epsilon"] = 0.0;
  if (eps == 2) scene["epsilon"] = 1e-2;
  if (eps == 3) scene["epsilon"] = target[3] * 1e-4;
  return scene;
}

std::uint64_t env_or(const char* name, std::uint64_t fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::strtoull(v, nullptr, 10) : fallback;
}

#if defined(__SANITIZE_ADDRESS__) || !defined(__OPTIMIZE__)
constexpr std::uint64_t kDefaultIterations = 300;  // Debug and ASan builds are ~50x slower
#else
constexpr std::uint64_t kDefaultIterations = 5000;  // about 1 s per precision
#endif

// One test per precision, each at width 1 (not for fast) and every packet width this CPU runs;
// auto (what `lancer render` does by default) at widths auto and 1.
class ExtremeNumbers : public ::testing::TestWithParam<Precision> {};

TEST_P(ExtremeNumbers, NoNanOrInfinityAtAnyWidth) {
  const Precision precision = GetParam();
  std::vector<int> widths;
  if (precision == Precision::automatic) {
    widths = {0, 1};  // auto: the widest the chosen precision runs, and the reference
  } else {
    for (int w : packet::supported_widths(precision))
      if (!(precision == Precision::fast && w == 1)) widths.push_back(w);
  }
  const std::uint64_t only = env_or("LANCER_NUMBERS_SEED", ~std::uint64_t(0));
  const std::uint64_t iterations = env_or("LANCER_NUMBERS_ITERATIONS", kDefaultIterations);
  int failing_seeds = 0;
  for (std::uint64_t it = 0; it < iterations && failing_seeds < 10; ++it) {
    const std::uint64_t seed = only != ~std::uint64_t(0) ? only : 0x5eed0000 + it;
    const json doc = extreme_scene(seed);
    SCOPED_TRACE("seed " + std::to_string(seed) + " (LANCER_NUMBERS_SEED=" + std::to_string(seed) +
                 "), scene: " + doc.dump());
    Scene scene;
    ASSERT_NO_THROW(scene = parse_scene(doc.dump(), "extreme.json"));
    bool seed_failed = false;
    for (int w : widths) {
      RenderOptions opt;
      opt.width = w;
      opt.precision = precision;
      opt.threads = 1;
      const Image im = render(scene, opt).image;
      bool bad = false;
      for (int j = 0; j < im.ny && !bad; ++j)
        for (int i = 0; i < im.nx && !bad; ++i)
          for (int c = 0; c < 3 && !bad; ++c) {
            const float v = im.pixel(i, j)[c];
            if (!std::isfinite(v)) {
              bad = true;
              ADD_FAILURE() << to_string(precision) << " width " << w << ": pixel (" << i << ", "
                            << j << ") channel " << c << " is " << v;
            }
          }
      seed_failed = seed_failed || bad;
    }
    failing_seeds += seed_failed;
    if (seed_failed && std::getenv("LANCER_NUMBERS_DUMP")) {
      // Write the scene out, e.g. for LANCER_FP_TRAPS_SCENES (test_fp_traps.cpp).
      std::ofstream(std::string(std::getenv("LANCER_NUMBERS_DUMP")) + "/extreme-" +
                    std::to_string(seed) + ".json")
          << doc.dump(2);
    }
    if (only != ~std::uint64_t(0)) break;
  }
}

INSTANTIATE_TEST_SUITE_P(Precisions, ExtremeNumbers,
                         ::testing::Values(Precision::exact, Precision::dbl, Precision::fast,
                                           Precision::automatic),
                         [](const ::testing::TestParamInfo<Precision>& param) {
                           return param.param == Precision::automatic
                                      ? std::string("auto")
                                      : std::string(to_string(param.param));
                         });

}  // namespace
}  // namespace lancer
