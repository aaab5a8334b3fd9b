// The loader's entries for triangles, meshes and cylinders (docs/scene-format.md, "More object
// types"): their fields, and a mesh's file read, transformed and checked.
#include <cmath>
#include <filesystem>
#include <string>

#include "lancer/mesh_io.hpp"
#include "lancer/scene.hpp"
#include "scene_reader.hpp"

namespace lancer::load {
namespace {

using rules::fail;
using rules::kMaxCoordinate;
using rules::kMinLength;
using rules::show;

Vec3<double> positive_scale(ObjectReader& o) {
  if (!o.has("scale")) return {1, 1, 1};
  const json& v = o.get("scale");
  const std::string at = o.at("scale");
  Vec3<double> sc;
  if (v.is_number()) {
    const double k = ObjectReader::as_number(v, at);
    sc = {k, k, k};
  } else if (v.is_array() && v.size() == 3) {
    sc = ObjectReader::as_vec3(v, at);
  } else {
    fail(at, "must be a positive number or an array of 3 positive numbers");
  }
  for (double k : {sc.x, sc.y, sc.z})
    if (!(k > 0) || k < kMinLength || k > kMaxCoordinate)
      fail(at, "must be from " + show(kMinLength) + " to " + show(kMaxCoordinate));
  return sc;
}

// A mesh file's path: absolute as written, else relative to the scene file's folder.
std::string mesh_path(const std::string& scene_name, const std::string& file) {
  const std::filesystem::path f(file);
  if (f.is_absolute()) return file;
  return (std::filesystem::path(scene_name).parent_path() / f).string();
}

void check_mesh_coordinates(const Mesh& m, const std::string& where) {
  for (const Vec3<double>& v : m.vertices)
    for (double c : {v.x, v.y, v.z})
      if (!(std::fabs(c) <= kMaxCoordinate))
        fail(where, "a vertex lies beyond " + show(kMaxCoordinate) + " after the transform");
}

}  // namespace

// "triangle", "mesh" and "cylinder": one Shape each.
void read_shape(ObjectReader& o, const std::string& type, int material, Scene& s) {
  Shape sh;
  if (type == "triangle") {
    const json& vs = o.get("vertices");
    if (!vs.is_array() || vs.size() != 3) fail(o.at("vertices"), "must be an array of 3 points");
    Mesh& m = sh.mesh;
    for (std::size_t k = 0; k < 3; ++k) {
      const std::string at = index_path(o.at("vertices"), k);
      const Vec3<double> v = ObjectReader::as_vec3(vs[k], at);
      for (double c : {v.x, v.y, v.z})
        if (std::fabs(c) > kMaxCoordinate)
          fail(at, "must be from " + show(-kMaxCoordinate) + " to " + show(kMaxCoordinate));
      m.vertices.push_back(v);
    }
    const Vec3<double> e = cross(m.vertices[1] - m.vertices[0], m.vertices[2] - m.vertices[0]);
    if (e.x == 0 && e.y == 0 && e.z == 0)
      fail(o.at("vertices"), "the three vertices lie on one line (zero area)");
    m.indices = {0, 1, 2};
    m.material = material;
    o.finish();
  } else if (type == "mesh") {
    const std::string file = o.string("file");
    MeshTransform t;
    t.scale = positive_scale(o);
    if (o.has("rotate")) t.rotate = o.point("rotate");
    if (o.has("translate")) t.translate = o.point("translate");
    const bool smooth = o.boolean_or("smooth", false);
    o.finish();
    const std::string path = mesh_path(s.name, file);
    Mesh& m = sh.mesh;
    m.file = file;
    m.material = material;
    try {
      place_mesh(read_mesh_file(path, path), t, smooth, path, m);
    } catch (const InputError& e) {
      fail(o.at("file"), e.what());
    }
    check_mesh_coordinates(m, o.at("file"));
    if (s.triangles() + m.triangles() > kMaxTriangles)
      fail(o.at("file"), "the scene's meshes hold more than " + std::to_string(kMaxTriangles) +
                             " triangles (docs/limits.md)");
  } else {
    sh.kind = Shape::Kind::cylinder;
    Cylinder& c = sh.cylinder;
    c.base = o.point("base");
    c.top = o.point("top");
    c.radius = o.length("radius");
    c.caps = o.boolean_or("caps", true);
    c.material = material;
    if (c.base.x == c.top.x && c.base.y == c.top.y && c.base.z == c.top.z)
      fail(o.at("top"), "must differ from base");
    o.finish();
  }
  s.shapes.push_back(std::move(sh));
}

}  // namespace lancer::load
