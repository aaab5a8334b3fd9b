// Mesh files for the scene's "mesh" objects: Wavefront OBJ and PLY (ascii or binary
// little-endian), read into triangles, then placed in the world by the object's transform.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "lancer/scene.hpp"
#include "lancer/vec3.hpp"

namespace lancer {

// A mesh file as read: positions, the file's normals, and triangles (faces of n corners as the
// fan (v0, v[i], v[i+1])), each corner with the index of the normal the file gives it or
// kNoNormal.
struct MeshFile {
  static constexpr std::uint32_t kNoNormal = 0xffffffffu;
  std::vector<Vec3<double>> positions;
  std::vector<Vec3<double>> normals;
  std::vector<std::uint32_t> indices;         // 3 per triangle
  std::vector<std::uint32_t> normal_indices;  // 3 per triangle, or empty: the file has no normal
};

// The most triangles one scene may hold (its meshes together): indices stay 32-bit with room,
// and at some 110 bytes a triangle at a float render's peak (docs/limits.md) this is 15 GB.
inline constexpr std::size_t kMaxTriangles = std::size_t(1) << 27;

// Reads `path` (named `shown` in messages) through read_input_file. The format is the
// extension's (.obj, .ply, any case). Bad input: InputError of one line naming the file and the
// line (OBJ, ascii PLY) or element (binary PLY): `m.obj:12: vertex index 9 out of range (1 to 8)`.
MeshFile read_mesh_file(const std::string& path, const std::string& shown);
MeshFile parse_obj(const std::string& text, const std::string& shown);
MeshFile parse_ply(const std::string& text, const std::string& shown);

// The object's placement: p' = translate + Rz(rz) Ry(ry) Rx(rx) (scale p), angles in degrees.
struct MeshTransform {
  Vec3<double> scale{1, 1, 1};
  Vec3<double> rotate{0, 0, 0};  // degrees about x, y, z, applied x first
  Vec3<double> translate{0, 0, 0};
};

// The file's triangles placed by `t` into `out` (its vertices, indices, dropped count and, when
// smooth, its per-corner normals). Triangles of zero area after the transform are dropped; none
// left is an InputError naming `shown`.
void place_mesh(MeshFile&& file, const MeshTransform& t, bool smooth, const std::string& shown,
                Mesh& out);

// The one bounded reader of input files (scenes, meshes): refuses what is not a regular file
// (folders, FIFOs, devices), files over 1 GiB, and unreadable ones. `what` names the kind in
// messages ("scene file", "mesh file").
std::string read_input_file(const std::string& path, const std::string& what);

}  // namespace lancer
