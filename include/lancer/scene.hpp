// The scene as read from a file: the model of SCENE-MODEL.md in double precision, validated.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "lancer/export.hpp"
#include "lancer/vec3.hpp"

namespace lancer {

struct Rgb {
  double r = 0, g = 0, b = 0;
};

struct Material {
  Rgb color{1, 1, 1};
  double ka = 0, kd = 1, ks = 0, shininess = 100, reflect = 0;
  double transmit = 0;  // share passed on by refraction
  double ior = 1;       // index of refraction, > 0
};

struct Light {
  Vec3<double> position{0, 0, 0};
  Rgb intensity{1, 1, 1}, ambient{0, 0, 0};  // colours: Lorenzi's lights are rgb triplets
};

enum class CameraType { pinhole, orthographic };

struct CameraSpec {
  CameraType type = CameraType::pinhole;
  Vec3<double> position{0, 0, 0};
  Vec3<double> direction{0, 0, -1};
  double distance = 1;  // pinhole only
  int nx = 1, ny = 1;
  double xmin = -1, xmax = 1, ymin = -1, ymax = 1;
};

struct Sphere {
  Vec3<double> center{0, 0, 0};
  double radius = 1;
  int material = 0;  // index into Scene::materials
};

struct Plane {
  Vec3<double> point{0, 0, 0};
  Vec3<double> normal{0, 1, 0};  // as written; normalised when the scene is prepared
  int material = 0;
};

// A triangle mesh (a lone "triangle" is a mesh of one): its vertices after the scene's transform,
// in double, and its triangles as index triples in file order (zero-area ones already dropped).
// Indexed, not expanded: a vertex shared by triangles is one set of coordinates, so every
// triangle meeting at it sees the same bits (the watertight test relies on it), and 10 million
// triangles take some 250 MB here (docs/limits.md).
struct Mesh {
  std::string file;  // as written in the scene ("" for a triangle), for messages
  std::vector<Vec3<double>> vertices;
  std::vector<std::uint32_t> indices;  // 3 per triangle: v0, v1, v2
  // smooth: unit vertex normals (transformed as normals), and per corner (3 per triangle) the
  // normal it takes; empty when not smooth.
  bool smooth = false;
  std::vector<Vec3<double>> normals;
  std::vector<std::uint32_t> normal_indices;
  std::size_t dropped = 0;  // zero-area triangles left out
  int material = 0;
  std::size_t triangles() const { return indices.size() / 3; }
};

// A capped or open cylinder: the points at `radius` from segment base-top, plus the two end
// discs when `caps`.
struct Cylinder {
  Vec3<double> base{0, 0, 0}, top{0, 1, 0};
  double radius = 1;
  bool caps = true;
  int material = 0;
};

// One "triangle", "mesh" or "cylinder" of the file, in file order.
struct Shape {
  enum class Kind { mesh, cylinder } kind = Kind::mesh;
  Mesh mesh;  // kind mesh (a "triangle" too)
  Cylinder cylinder;
};

// Spheres and planes are kept apart. Every path tests spheres first, then planes, each in file
// order, and keeps the first of equally near hits: that fixes the tie-break the contract leaves
// open, identically for the reference and the packets. Shapes (triangles, meshes, cylinders) come
// after the planes, in file order: object ids spheres, then planes, then shapes.
struct Scene {
  std::string name;  // file name, for messages
  CameraSpec camera;
  Rgb background;
  Rgb environment;
  int max_depth = 0;
  double epsilon = 1e-4;
  int supersample = 1;
  std::vector<Material> materials;  // named and inline, in order of appearance
  std::vector<Light> lights;
  std::vector<Sphere> spheres;
  std::vector<Plane> planes;
  std::vector<Shape> shapes;
  std::size_t triangles() const {
    std::size_t n = 0;
    for (const Shape& sh : shapes) n += sh.mesh.triangles();
    return n;
  }
  std::size_t num_objects() const { return spheres.size() + planes.size() + shapes.size(); }
};

// Limits that keep a render from exhausting memory or recursing without end.
inline constexpr int kMaxDepth = 64;
inline constexpr long long kMaxSamples = 1LL << 30;  // nx * ny * supersample^2
inline constexpr int kMaxResolution = 1 << 16;       // per axis
inline constexpr int kMaxSupersample = 64;
// Counts in a scene file. Objects: above 2^24 (indices are 32-bit integers, never floats), and
// about what 1 GiB of JSON can hold (a minimal sphere takes 46 bytes: 23 million) at some 150
// bytes each once loaded, prepared in both precisions and indexed. Lights are visited by every
// shading point, so tens of thousands are already far beyond any useful render; named materials
// likewise.
inline constexpr std::size_t kMaxObjects = std::size_t(1) << 25;
inline constexpr std::size_t kMaxLights = std::size_t(1) << 16;
inline constexpr std::size_t kMaxNamedMaterials = std::size_t(1) << 16;
// A material that both reflects and transmits splits every ray it meets in two, so the ray tree
// grows as 2^max_depth: scenes with such a material and a deeper max_depth are refused up front
// (2^(12+1) - 1 = 8191 rays per camera ray at worst).
inline constexpr int kMaxSplitDepth = 12;

// Throws InputError with a one-line message naming the place: `objects[2].radius: must be > 0`
// or `scene.json:14: syntax error ...`.
// The file is parsed as a stream: each object, light and material is converted as soon as it
// is read, and nothing proportional to the document's size but the scene itself is kept.
LANCER_API Scene parse_scene(const std::string& text, const std::string& name);
LANCER_API Scene load_scene(const std::string& path);
// Also records, for each entry of the file's "objects" in order, whether it is a plane (lancer
// flux names objects by their place in the file).
LANCER_API Scene parse_scene(const std::string& text, const std::string& name,
                             std::vector<bool>* is_plane);
// The one reader of scene files for every command: refuses folders and files over 1 GiB (also
// when the size is not known beforehand: /dev/zero, pipes).
LANCER_API std::string read_scene_file(const std::string& path);

}  // namespace lancer
