#include "lancer/generate.hpp"

#include <cmath>
#include <cstdio>
#include <string>
#include <unordered_map>

#include "lancer/error.hpp"
#include "lancer/mesh_io.hpp"
#include "lancer/scene.hpp"

namespace lancer::generate {

std::uint64_t SplitMix64::below(std::uint64_t n) {
  // Rejects the top 2^64 mod n values so that every remainder is equally likely.
  const std::uint64_t threshold = (0 - n) % n;
  for (;;) {
    const std::uint64_t x = next();
    if (x >= threshold) return x % n;
  }
}

namespace {

// Millionths of a unit: every coordinate is an integer, printed exactly.
using Micro = long long;
constexpr Micro kUnit = 1000000;

// The box the spheres fill (units): x in [-5, 5], y in [0, 5] above the ground, z in [-15, -5].
constexpr Micro kHalfX = 5 * kUnit, kHeight = 5 * kUnit, kNear = -5 * kUnit, kFar = -15 * kUnit;

// Cube root by Newton's method in plain IEEE arithmetic (no libm: results must not depend on it).
double cube_root(double v) {
  double x = 1;
  while (x * x * x < v) x *= 2;
  for (int i = 0; i < 100; ++i) x = (2 * x + v / (x * x)) / 3;
  return x;
}

void put_micro(std::string& out, Micro v) {
  char buf[32];
  const bool negative = v < 0;
  unsigned long long a = negative ? 0ull - static_cast<unsigned long long>(v) : v;
  char* end = buf + sizeof buf;
  char* p = end;
  unsigned long long frac = a % kUnit, whole = a / kUnit;
  if (frac != 0) {
    int digits = 6;
    while (frac % 10 == 0) frac /= 10, --digits;
    for (int i = 0; i < digits; ++i) *--p = static_cast<char>('0' + frac % 10), frac /= 10;
    *--p = '.';
  }
  do *--p = static_cast<char>('0' + whole % 10), whole /= 10;
  while (whole);
  if (negative) *--p = '-';
  out.append(p, end);
}

void put_number(std::string& out, double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.9g", v);  // option values as given: exact for 3 decimals
  out += buf;
}

constexpr int kMaterials = 16;

}  // namespace

std::string scene_json(const Options& o) {
  if (o.cylinders < 0 || o.cylinders > static_cast<long long>(kMaxObjects) / 2)
    throw InputError("--cylinders: must be from 0 to " + std::to_string(kMaxObjects / 2));
  if (o.spheres < 0 || o.spheres > static_cast<long long>(kMaxObjects) - 1)
    throw InputError("--spheres: must be from 0 to " + std::to_string(kMaxObjects - 1));
  if (!(o.reflect >= 0 && o.reflect <= 1)) throw InputError("--reflect: must be from 0 to 1");
  if (o.transmit >= 0 && !(o.transmit <= 1)) throw InputError("--transmit: must be from 0 to 1");
  if (!(o.transmit_spread >= 0 && o.transmit_spread <= 1))
    throw InputError("--transmit-spread: must be from 0 to 1");
  if (o.transmit_spread > 0 && !(o.transmit >= 0))
    throw InputError("--transmit-spread: needs --transmit");
  if (o.ior >= 0 && !(o.ior >= 1 && o.ior <= 10)) throw InputError("--ior: must be from 1 to 10");
  if (o.nx < 1 || o.ny < 1 || o.nx > kMaxResolution || o.ny > kMaxResolution)
    throw InputError("--resolution: must be from 1 to " + std::to_string(kMaxResolution) +
                     " per axis");
  SplitMix64 rng{o.seed};

  // Mean radius for a constant 15% of the box filled, whatever N: denser, smaller spheres as N
  // grows, the same picture at every scale. Radii vary from 0.5 to 1.5 times it.
  const double volume = 10.0 * 5.0 * 10.0;
  const double n = o.spheres > 0 ? static_cast<double>(o.spheres) : 1.0;
  const double mean = cube_root(0.15 * volume * 3 / (4 * 3.14159265358979 * n));
  Micro r_mean = static_cast<Micro>(mean * kUnit);
  if (r_mean > kHeight / 4) r_mean = kHeight / 4;  // a few spheres still fit the box
  if (r_mean < 4) r_mean = 4;

  std::string out;
  out.reserve(static_cast<std::size_t>(o.spheres) * 80 + 4096);
  // A pinhole camera 10 units before the box, looking a little down: it sees the whole box.
  const double aspect = static_cast<double>(o.nx) / o.ny;
  out += "{\n  \"camera\": {\"type\": \"pinhole\", \"position\": [0, 2.5, 5], ";
  out += "\"direction\": [0, -0.12, -1], \"distance\": 1, \"resolution\": [";
  out += std::to_string(o.nx) + ", " + std::to_string(o.ny) + "], \"bounds\": [";
  put_number(out, -0.5 * aspect);
  out += ", ";
  put_number(out, 0.5 * aspect);
  out += ", -0.5, 0.5]},\n  \"background\": [0.05, 0.07, 0.12],\n";
  const bool deep = o.reflect > 0 || o.transmit > 0;
  out += "  \"max_depth\": " + std::string(deep ? "3" : "0") + ",\n";
  out += "  \"lights\": [{\"position\": [-10, 20, 10], \"intensity\": 0.7, \"ambient\": 0.15}, ";
  out += "{\"position\": [15, 10, 5], \"intensity\": 0.4}],\n  \"materials\": {\n";
  for (int m = 0; m < kMaterials; ++m) {
    // Colours from the generator too, in steps of 1/1000.
    out += "    \"m" + std::to_string(m) + "\": {\"color\": [";
    for (int c = 0; c < 3; ++c) {
      if (c) out += ", ";
      put_micro(out, static_cast<Micro>(200 + rng.below(800)) * 1000);
    }
    out += "], \"ka\": 0.1, \"kd\": 0.8, \"ks\": 0.4, \"shininess\": 40";
    if (o.reflect > 0) out += ", \"reflect\": ", put_number(out, o.reflect);
    if (o.transmit >= 0) {
      out += ", \"transmit\": ";
      put_number(out, o.transmit_spread > 0
                          ? o.transmit * (1 - o.transmit_spread * m / (kMaterials - 1))
                          : o.transmit);
    }
    if (o.ior >= 0) out += ", \"ior\": ", put_number(out, o.ior);
    out += "},\n";
  }
  out += "    \"ground\": {\"color\": [0.6, 0.6, 0.55], \"ka\": 0.1, \"kd\": 0.8}\n  },\n";
  out += "  \"objects\": [\n";
  bool first = true;
  if (o.plane) {
    out += "    {\"type\": \"plane\", \"point\": [0, 0, 0], \"normal\": [0, 1, 0], ";
    out += "\"material\": \"ground\"}";
    first = false;
  }
  for (long long i = 0; i < o.spheres; ++i) {
    const Micro r = r_mean / 2 + static_cast<Micro>(rng.below(static_cast<std::uint64_t>(r_mean)));
    const Micro x = -kHalfX + r + static_cast<Micro>(rng.below(2 * (kHalfX - r)));
    const Micro y = r + static_cast<Micro>(rng.below(kHeight - 2 * r));
    const Micro z = kFar + r + static_cast<Micro>(rng.below(kNear - kFar - 2 * r));
    const int m = static_cast<int>(rng.below(kMaterials));
    out += first ? "    {\"type\":\"sphere\",\"center\":["
                 : ",\n    {\"type\":\"sphere\",\"center\":[";
    first = false;
    put_micro(out, x);
    out += ',';
    put_micro(out, y);
    out += ',';
    put_micro(out, z);
    out += "],\"radius\":";
    put_micro(out, r);
    out += ",\"material\":\"m" + std::to_string(m) + "\"}";
  }
  if (!o.mesh_file.empty()) {
    out += first ? "    " : ",\n    ";
    first = false;
    out += "{\"type\": \"mesh\", \"file\": \"" + o.mesh_file +
           "\", \"scale\": 1.5, \"translate\": [0, 2.5, -5], \"material\": \"m0\"}";
  }
  for (long long i = 0; i < o.cylinders; ++i) {
    const Micro r = r_mean / 4 + static_cast<Micro>(rng.below(static_cast<std::uint64_t>(r_mean)));
    const Micro x = -kHalfX + 2 * r + static_cast<Micro>(rng.below(2 * (kHalfX - 2 * r)));
    const Micro z = kFar + 2 * r + static_cast<Micro>(rng.below(kNear - kFar - 4 * r));
    const Micro h = 2 * r + static_cast<Micro>(rng.below(kHeight / 2));
    const int m = static_cast<int>(rng.below(kMaterials));
    out += first ? "    " : ",\n    ";
    first = false;
    out += "{\"type\":\"cylinder\",\"base\":[";
    put_micro(out, x), out += ",0,", put_micro(out, z);
    out += "],\"top\":[";
    put_micro(out, x + r), out += ',', put_micro(out, h), out += ',', put_micro(out, z);
    out += "],\"radius\":";
    put_micro(out, r);
    out += ",\"material\":\"m" + std::to_string(m) + "\"}";
  }
  out += "\n  ]\n}\n";
  return out;
}

std::string sphere_ply(long long triangles, long long* written) {
  if (triangles < 1 || triangles > static_cast<long long>(kMaxTriangles))
    throw InputError("--mesh-triangles: must be from 1 to " + std::to_string(kMaxTriangles));
  long long n = 1;
  while (12 * n * n < triangles) ++n;
  // Vertices: the cube [-n, n]^3's surface points of even coordinates... on the grid of step 2,
  // numbered as first met.
  std::unordered_map<std::uint64_t, std::uint32_t> ids;
  ids.reserve(static_cast<std::size_t>(6 * (n + 1) * (n + 1)));
  std::string verts, faces;
  std::uint32_t count = 0;
  auto vertex = [&](long long a, long long b, long long c) {
    const std::uint64_t key =
        (std::uint64_t(a + n) * std::uint64_t(2 * n + 1) + std::uint64_t(b + n)) *
            std::uint64_t(2 * n + 1) +
        std::uint64_t(c + n);
    auto [it, added] = ids.emplace(key, count);
    if (added) {
      const double len = std::sqrt(double(a * a + b * b + c * c));
      const float p[3] = {float(a / len), float(b / len), float(c / len)};
      verts.append(reinterpret_cast<const char*>(p), sizeof p);
      ++count;
    }
    return it->second;
  };
  long long tris = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = -1; side <= 1; side += 2)
      for (long long i = 0; i < n; ++i)
        for (long long j = 0; j < n; ++j) {
          auto corner = [&](long long di, long long dj) {
            long long q[3];
            q[axis] = side * n, q[(axis + 1) % 3] = 2 * (i + di) - n,
            q[(axis + 2) % 3] = 2 * (j + dj) - n;
            return vertex(q[0], q[1], q[2]);
          };
          const std::uint32_t c[4] = {corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)};
          const std::uint32_t f[2][3] = {{c[0], c[1], c[2]}, {c[0], c[2], c[3]}};
          for (const auto& t : f) {
            faces.push_back(char(3));
            std::uint32_t v[3] = {t[0], side > 0 ? t[1] : t[2], side > 0 ? t[2] : t[1]};
            faces.append(reinterpret_cast<const char*>(v), sizeof v);
            ++tris;
          }
        }
  if (written) *written = tris;
  return "ply\nformat binary_little_endian 1.0\ncomment lancer generate: unit sphere\n"
         "element vertex " +
         std::to_string(count) +
         "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
         std::to_string(tris) + "\nproperty list uchar int vertex_indices\nend_header\n" + verts +
         faces;
}

}  // namespace lancer::generate
