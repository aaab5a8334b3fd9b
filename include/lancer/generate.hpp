// Random-sphere scenes for scaling measurements (`lancer generate`): N spheres in a box the
// camera sees, on a ground plane, under two lights. The same options give the same bytes on any
// machine and compiler: an own PRNG (splitmix64), integer coordinates in millionths, and no
// std:: distribution or libm call (their results are implementation-defined).
#pragma once

#include <cstdint>
#include <string>

namespace lancer::generate {

struct Options {
  long long spheres = 1024;
  std::uint64_t seed = 1;
  double reflect = 0;              // every sphere's reflectivity
  double transmit = -1, ior = -1;  // emitted only when given (>= 0)
  // Material m's transmit is transmit * (1 - transmit_spread * m / 15): differing transmits, so
  // that a product over the spheres a shadow ray crosses depends on its order (validate then
  // checks that order too). 0: every sphere the same.
  double transmit_spread = 0;
  bool plane = true;       // a ground plane under the box
  int nx = 600, ny = 400;  // camera resolution
  // A mesh in the middle of the box: its file's name as the scene gives it (beside the scene),
  // written by the caller from sphere_ply(); none when empty.
  std::string mesh_file;
  long long cylinders = 0;  // cylinders among the spheres
};

// The unit sphere as a cube's faces of n x n quads pushed onto it (n chosen so the count is at
// least `triangles`, 12 n^2 triangles, vertices shared), as binary little-endian PLY. Only
// integer arithmetic, division and sqrt (correctly rounded everywhere): the same bytes on any
// machine. InputError beyond kMaxTriangles.
std::string sphere_ply(long long triangles, long long* written = nullptr);

// Checks the options (InputError naming the option) and returns the scene as JSON text.
std::string scene_json(const Options& o);

// The deterministic generator: splitmix64 (Steele, Lea, Flood 2014).
struct SplitMix64 {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, n), n > 0, without modulo bias.
  std::uint64_t below(std::uint64_t n);
};

}  // namespace lancer::generate
