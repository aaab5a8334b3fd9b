// Seeded random scenes in the JSON format of docs/scene-format.md, for comparing the
// engine with tests/oracle (or the engine with itself) on many scenes.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>

namespace lancer::testing {

struct RandomSceneOptions {
  int max_objects = 64;      // 1..max_objects objects, small counts more likely
  bool planes = true;        // allow a few infinite planes among the (mostly) spheres
  double min_radius = 0.05;  // sphere radii are log-uniform in [min_radius, max_radius]
  double max_radius = 5;
  double min_distance = 0.5;  // object distances from the origin are log-uniform in
  double max_distance = 50;   //   [min_distance, max_distance]
  int max_depth = 8;          // the scene's max_depth is uniform in 0..max_depth
  int nx = 37;                // resolution; deliberately not multiples of 4, 8 or 16
  int ny = 23;
  // Transparent materials (transmit, ior; some below 1, so that rays arriving from outside are
  // totally reflected past the critical angle; many both reflect and transmit) and coloured
  // lights (intensity, ambient as [r, g, b]).
  bool glass = true;
};

// A valid scene, the same for the same seed and options on every run and machine (up to the
// last bit of std::log/std::exp). Some optional fields are left out to exercise the defaults.
nlohmann::json random_scene(uint64_t seed, const RandomSceneOptions& opt = {});

}  // namespace lancer::testing
