// The oracle's model of a scene (docs/scene-format.md) and its loader (oracle_parse.cpp):
// plain double-precision values, written from the contract alone, apart from the engine.
#pragma once

#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

namespace oracle {

// ---------------------------------------------------------------------------------------------
// Vectors and colours

struct Vec {
  double x = 0, y = 0, z = 0;
};

inline Vec operator+(Vec a, Vec b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec operator-(Vec a, Vec b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec operator-(Vec a) { return {-a.x, -a.y, -a.z}; }
inline Vec operator*(double s, Vec a) { return {s * a.x, s * a.y, s * a.z}; }
inline double dot(Vec a, Vec b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec cross(Vec a, Vec b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double length(Vec a) { return std::sqrt(dot(a, a)); }
inline Vec normalize(Vec a) {
  double len = length(a);
  return {a.x / len, a.y / len, a.z / len};
}
inline bool is_zero(Vec a) { return a.x == 0 && a.y == 0 && a.z == 0; }

struct Rgb {
  double r = 0, g = 0, b = 0;
};

inline Rgb operator+(Rgb a, Rgb b) { return {a.r + b.r, a.g + b.g, a.b + b.b}; }
inline Rgb operator*(double s, Rgb a) { return {s * a.r, s * a.g, s * a.b}; }
inline Rgb operator*(Rgb a, Rgb b) { return {a.r * b.r, a.g * b.g, a.b * b.b}; }

// ---------------------------------------------------------------------------------------------
// Scene

struct Material {
  Rgb color{1, 1, 1};
  double ka = 0, kd = 1, ks = 0, shininess = 100, reflect = 0;
  double transmit = 0, ior = 1;
};

struct Light {
  Vec position;
  Rgb intensity{1, 1, 1}, ambient{0, 0, 0};
};

enum class Shape { kSphere, kPlane, kTriangle, kCylinder };

struct Object {
  Shape shape = Shape::kSphere;
  Vec center;         // sphere centre, or a point of the plane
  Vec normal;         // plane only: unit normal
  double radius = 0;  // sphere and cylinder
  Vec v[3];           // triangle: its vertices; cylinder: v[0] base, v[1] top
  bool caps = true;   // cylinder
  Material material;
};

struct Camera {
  bool pinhole = true;
  Vec position, direction;
  double distance = 0;
  int nx = 0, ny = 0;
  double xmin = 0, xmax = 0, ymin = 0, ymax = 0;
};

struct Scene {
  Camera camera;
  Rgb background, environment;
  int max_depth = 0;
  double epsilon = 1e-4;
  int supersample = 1;
  std::vector<Light> lights;
  std::vector<Object> objects;
};

// Bad input: one line naming the place, like the engine's.
struct BadInput : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The scene of a parsed JSON document; BadInput names the first bad place.
Scene parse_scene(const nlohmann::json& j);

}  // namespace oracle
