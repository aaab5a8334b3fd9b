// The scene rules the file loader (scene_load.cpp) and the library API's descriptions built in
// code (api.cpp) are both held to: one function per rule, each failing with the same one-line
// message, `where: what`, whichever of the two asked.
#pragma once

#include <string>
#include <vector>

#include "lancer/scene.hpp"

namespace lancer::rules {

// Ranges beyond the contract's own rules, so that a render in single precision stays finite
// (issue 7; each was a fuzzing finding, kept in tests/fuzz/test_regressions.cpp):
// - coordinates (positions, centres, points, bounds) and lengths (radius, distance) at most
//   kMaxCoordinate in magnitude: squared distances between them stay below FLT_MAX;
// - radius and distance at least kMinLength: their squares stay normal floats, not 0;
// - brightness (colours, coefficients, intensities, background) at most kMaxRadiance, and so the
//   brightest radiance the scene can produce (scene_radiance_bound), times 64^2 sub-samples
//   summed, stays below FLT_MAX;
// - shininess at most kMaxShininess: a cosine one float step above 1 raised to it stays near 1.
inline constexpr double kMaxCoordinate = 1e18;
inline constexpr double kMinLength = 1e-18;
inline constexpr double kMaxRadiance = 1e34;
inline constexpr double kMaxShininess = 1e6;
// - ior from 1/kMaxIor to kMaxIor: eta^2 in the refracted direction stays a normal float.
inline constexpr double kMaxIor = 1e6;

[[noreturn]] void fail(const std::string& where, const std::string& what);
std::string show(double v);  // %g
std::string index_path(const std::string& parent, std::size_t i);

// Each checks one value named `where` and returns it (direction: rescaled).
double finite(const std::string& where, double v);
// >= 0 and at most max_value: a colour channel, a coefficient, shininess.
double non_negative(const std::string& where, double v, double max_value = kMaxRadiance);
double length(const std::string& where, double v);  // a radius or a distance
Vec3<double> point(const std::string& where, const Vec3<double>& v);
// Of any non-zero length. One far from 1 is scaled by a power of two, which changes no bit of
// its normalised value but keeps |v|^2 from underflowing or overflowing.
Vec3<double> direction(const std::string& where, const Vec3<double>& v);
Rgb colour(const std::string& where, const Rgb& c);  // every component

// The camera's parts, in the order the loader reads them; `where` is "camera".
CameraType camera_type(const std::string& where, CameraType type);  // one of the two
Vec3<double> camera_direction(const std::string& where, const Vec3<double>& d);
void resolution(const std::string& where, int nx, int ny);
void bounds(const std::string& where, const double v[4]);

// A material's coefficients, in the order the loader reads them, with their upper bounds.
struct MaterialCoefficient {
  const char* key;
  double Material::*member;
  double max_value;
};
inline constexpr MaterialCoefficient kMaterialCoefficients[] = {
    {"ka", &Material::ka, kMaxRadiance},
    {"kd", &Material::kd, kMaxRadiance},
    {"ks", &Material::ks, kMaxRadiance},
    {"shininess", &Material::shininess, kMaxShininess},
    {"reflect", &Material::reflect, kMaxRadiance},
    {"transmit", &Material::transmit, kMaxRadiance}};
double ior(const std::string& where, double v);

// The top level's numbers.
int max_depth(int v);
double epsilon(double v);
int supersample(int v);
void object_count(std::size_t n);
void light_count(std::size_t n);

// The whole scene's rules, once every part is read; material_where[m] names material m.
// fn(material index) for each object's material: spheres, planes, then shapes, in file order.
template <class Fn>
void for_each_material(const Scene& s, Fn fn) {
  for (const Sphere& sp : s.spheres) fn(sp.material);
  for (const Plane& p : s.planes) fn(p.material);
  for (const Shape& sh : s.shapes)
    fn(sh.kind == Shape::Kind::mesh ? sh.mesh.material : sh.cylinder.material);
}

void ray_tree(const Scene& s, const std::vector<std::string>& material_where);
void radiance(const Scene& s, const std::vector<std::string>& material_where);
void sample_count(const Scene& s);  // nx * ny * supersample^2

// A scene built in code, held to every rule above in the loader's order and with its messages,
// places named as in a file whose "objects" are the spheres then the planes and whose
// materials are listed by index (`materials[2].kd`). Directions are rescaled as the loader does.
// InputError "<name>: <place>: <what>", name being scene.name or "scene".
void check_description(Scene& scene);

}  // namespace lancer::rules
